// SPDX-License-Identifier: MIT
// Malformed-file tests: being written.
