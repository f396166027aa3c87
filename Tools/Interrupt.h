// SPDX-License-Identifier: MIT
#pragma once
/// @file Interrupt.h
/// @brief Ctrl-C (SIGINT), SIGTERM, SIGHUP (a terminal closed) and SIGPIPE (the reader of its output
/// gone: `csgv render --video ... | head`) for every `csgv` command: the handler only asks Core to
/// cancel (requestCancel, polled by progress callbacks and derived SQL), and a watchdog thread
/// makes the promise hold when the work cannot notice in time (a library call such as libhdf5's
/// or libtiff's that runs for minutes): 0.4 s after the signal it removes every temporary the
/// process made (removeTemporaries) and ends it with status 130 and one error line. So an
/// interrupt ends the tool within a second and never leaves a partial output, and the old files
/// it would have replaced stay as they were (outputs are only renamed into place when complete).

#include "csgv/base/Cancel.h"
#include "csgv/base/FileUtil.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>
#include <thread>
#include <unistd.h>

namespace csgv {

/// Exit status of a command ended by SIGINT, SIGTERM, SIGHUP or SIGPIPE (the shell's 128 + SIGINT).
constexpr int kInterruptedExit = 130;

namespace interrupt {

inline volatile std::sig_atomic_t g_signal = 0;
/// Set by the first "csgv: error:" line written, so that the watchdog and the command never
/// both write one.
inline std::atomic<bool> g_reported{false};

extern "C" inline void onSignal(int sig) {
    g_signal = sig;
    requestCancel();
}

/// The text with what could forge a line or drive a terminal written as escapes: C0 and C1
/// control characters (\n, \r, \t, \xNN; C1 also as UTF-8), bytes that are no valid UTF-8
/// (\xNN), and the bidirectional overrides and isolates (\u202E...) that reorder what is shown. A
/// name in a message (a slice named with a newline, libtiff's words about it) stays on its line.
inline std::string oneLine(const char* text) {
    std::string out;
    char esc[12];
    const auto* c = reinterpret_cast<const unsigned char*>(text);
    while (*c) {
        const unsigned char u = *c;
        if (u >= 0x20 && u < 0x7f) {
            out += char(u);
            ++c;
            continue;
        }
        if (u == '\n' || u == '\r' || u == '\t') {
            out += u == '\n' ? "\\n" : u == '\r' ? "\\r" : "\\t";
            ++c;
            continue;
        }
        // A UTF-8 sequence: its length from the lead byte, continuation bytes 10xxxxxx.
        const int length = u >= 0xc2 && u <= 0xdf ? 2 : u >= 0xe0 && u <= 0xef ? 3 : u >= 0xf0 && u <= 0xf4 ? 4 : 0;
        bool valid = length > 0;
        uint32_t cp = length == 2 ? u & 0x1f : length == 3 ? u & 0x0f : u & 0x07;
        for (int k = 1; valid && k < length; ++k) {
            valid = (c[k] & 0xc0) == 0x80;
            cp = (cp << 6) | (c[k] & 0x3f);
        }
        valid = valid && !(length == 3 && (cp < 0x800 || (cp >= 0xd800 && cp <= 0xdfff))) &&
                !(length == 4 && (cp < 0x10000 || cp > 0x10ffff));
        if (!valid) {
            std::snprintf(esc, sizeof esc, "\\x%02x", u); // C0 controls, DEL, stray bytes
            out += esc;
            ++c;
            continue;
        }
        if ((cp >= 0x80 && cp <= 0x9f) || (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2066 && cp <= 0x2069)) {
            std::snprintf(esc, sizeof esc, "\\u%04X", unsigned(cp));
            out += esc;
        } else {
            out.append(reinterpret_cast<const char*>(c), size_t(length));
        }
        c += length;
    }
    return out;
}

/// The line cut in the middle where it is longer than a screen or two: a name of a megabyte (a
/// path, a repeated option) is not echoed whole. Its start and end stay, the message's sense.
inline std::string boundedLine(std::string line) {
    constexpr size_t kHead = 1500, kTail = 300;
    if (line.size() <= kHead + kTail + 64) return line;
    size_t head = kHead, tail = line.size() - kTail;
    while (head > 0 && (static_cast<unsigned char>(line[head]) & 0xc0) == 0x80) --head; // whole UTF-8 sequences
    while (tail < line.size() && (static_cast<unsigned char>(line[tail]) & 0xc0) == 0x80) ++tail;
    return line.substr(0, head) + " ... (" + std::to_string(tail - head) + " characters left out) ... " + line.substr(tail);
}

/// The line for work stopped by the signal that came (g_signal).
inline const char* stoppedLine() {
    return g_signal == SIGTERM   ? "terminated (SIGTERM): stopped, no output written"
           : g_signal == SIGHUP  ? "hung up (SIGHUP): stopped, no output written"
           : g_signal == SIGPIPE ? "its output's reader is gone (SIGPIPE): stopped, no output written"
                                 : "interrupted (Ctrl-C): stopped, no output written";
}

/// Writes the one error line unless one was written already; false when it was.
inline bool reportOnce(const char* text) {
    if (g_reported.exchange(true)) return false;
    std::fprintf(stderr, "csgv: error: %s\n", boundedLine(oneLine(text)).c_str());
    std::fflush(stderr);
    return true;
}

/// A command's failure: its one error line, exit status 1. Work that gave up because a signal came
/// (a decode, a write between pieces, a cancelled encoding, a render) says the signal's line, which
/// names it, instead of what its giving up looked like.
inline int failed(const std::string& message) {
    reportOnce(g_signal != 0 ? stoppedLine() : message.c_str());
    return 1;
}

/// @brief Installed for the whole run by main(): signal handlers plus the watchdog thread.
class Guard {
public:
    Guard() {
        struct sigaction sa {};
        sa.sa_handler = onSignal;
        sigemptyset(&sa.sa_mask);
        sa.sa_flags = SA_RESTART;
        sigaction(SIGINT, &sa, nullptr);
        sigaction(SIGTERM, &sa, nullptr);
        // A hang-up (the terminal closed, an ssh session lost) is honoured like an interrupt, and
        // so is a write to a pipe whose reader is gone (its default action ended the tool at once,
        // leaving the temporaries of `render --video ... | head`: 74 of them in an attack pass);
        // either stays ignored when it was at the start (nohup).
        for (int sig : {SIGHUP, SIGPIPE})
            if (!signalIgnored(sig)) sigaction(sig, &sa, nullptr);
        try {
            m_thread = std::thread([this] { watch(); });
        } catch (const std::exception&) {
            // No thread to be had (a tight memory limit): cancellation through progress alone.
        }
    }
    ~Guard() {
        m_done = true;
        if (m_thread.joinable()) m_thread.join();
    }
    Guard(const Guard&) = delete;
    Guard& operator=(const Guard&) = delete;

    static bool interrupted() { return g_signal != 0; }

private:
    void watch() {
        using clock = std::chrono::steady_clock;
        while (!m_done && !g_signal) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        if (m_done) return;
        // The work's own cancellation (progress callbacks) usually ends it well before this.
        const auto deadline = clock::now() + std::chrono::milliseconds(400);
        while (!m_done && clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        if (m_done) return;
        // Not between the renames of a set being published: wait for them (microseconds), and
        // hold the lock until the process ends so that no other set starts.
        const PublishingHold publishing = holdPublishing();
        removeTemporaries();
        reportOnce(stoppedLine());
        std::fflush(stdout);
        ::_exit(kInterruptedExit);
    }

    std::atomic<bool> m_done{false};
    std::thread m_thread;
};

} // namespace interrupt
} // namespace csgv
