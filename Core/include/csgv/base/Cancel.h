// SPDX-License-Identifier: MIT
#pragma once
/// @file Cancel.h
/// @brief A process-wide request to stop, set from a signal handler (the `csgv` tool's Ctrl-C) and
/// polled by work that has no progress callback of its own to ask (derived SQL, long loops in
/// libraries' callbacks). Work with a progress callback cancels through it as before; ParaView's
/// Abort reaches Core that way, never through this flag.

namespace csgv {

/// Asks every poller to stop. Async-signal-safe (one lock-free atomic store).
void requestCancel() noexcept;
/// True once requestCancel() was called (until resetCancel()).
bool cancelRequested() noexcept;
void resetCancel() noexcept;

} // namespace csgv
