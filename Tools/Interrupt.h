// SPDX-License-Identifier: MIT
#pragma once
/// @file Interrupt.h
/// @brief Ctrl-C (SIGINT) and SIGTERM for every `csgv` command: the handler only asks Core to
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
#include <cstdio>
#include <exception>
#include <string>
#include <thread>
#include <unistd.h>

namespace csgv {

/// Exit status of a command ended by SIGINT or SIGTERM (the shell's 128 + SIGINT).
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

/// The text with its control characters written as \n, \r, \t or \xNN: a name in a message (a
/// slice named with a newline, a terminal escape, libtiff's words about it) can neither forge a
/// second "csgv: error:" line nor drive the terminal.
inline std::string oneLine(const char* text) {
    std::string out;
    for (const char* c = text; *c; ++c) {
        const unsigned char u = static_cast<unsigned char>(*c);
        if (u >= 0x20 && u != 0x7f) out += *c;
        else if (u == '\n') out += "\\n";
        else if (u == '\r') out += "\\r";
        else if (u == '\t') out += "\\t";
        else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", u);
            out += hex;
        }
    }
    return out;
}

/// Writes the one error line unless one was written already; false when it was.
inline bool reportOnce(const char* text) {
    if (g_reported.exchange(true)) return false;
    std::fprintf(stderr, "csgv: error: %s\n", oneLine(text).c_str());
    std::fflush(stderr);
    return true;
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
        const std::unique_lock<std::mutex> publishing = holdPublishing();
        removeTemporaries();
        reportOnce(g_signal == SIGTERM ? "terminated (SIGTERM): stopped, no output written"
                                       : "interrupted (Ctrl-C): stopped, no output written");
        std::fflush(stdout);
        ::_exit(kInterruptedExit);
    }

    std::atomic<bool> m_done{false};
    std::thread m_thread;
};

} // namespace interrupt
} // namespace csgv
