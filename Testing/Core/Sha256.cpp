// SPDX-License-Identifier: MIT
// SHA-256 of the fixtures (their published hashes) through OpenSSL's libcrypto, which ParaView
// already links.
#include "TestData.h"

#include <openssl/evp.h>

#include <cstdio>

namespace csgvtest {

std::string sha256Hex(const uint8_t* data, size_t size) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    if (EVP_Digest(data, size, digest, &length, EVP_sha256(), nullptr) != 1 || length != 32) return std::string();
    char hex[65];
    for (unsigned k = 0; k < 32; ++k) std::snprintf(hex + 2 * k, 3, "%02x", digest[k]);
    return std::string(hex, 64);
}

} // namespace csgvtest
