// SPDX-License-Identifier: MIT
#pragma once
/// @file CommandLine.h
/// @brief The one command-line parser of `csgv` (CLI11) as every subcommand uses it: CLI11
/// splits the words (flags, options with values, `--name=value`, positionals), the commands
/// convert the values with their own messages (ValueOptions), and every parse error is one
/// line for "csgv: error: ...".

#include "csgv/base/Status.h"

#include <CLI/CLI.hpp>
#include <sys/resource.h>

#include <algorithm>
#include <functional>
#include <map>
#include <utility>
#include <string>
#include <vector>

namespace csgv {

/// The process's peak resident memory in MiB (getrusage; Linux counts KiB): the commands'
/// `peak_memory_mib` and `host_peak_rss_mib`.
inline double peakRssMiB() {
    struct rusage ru {};
    ::getrusage(RUSAGE_SELF, &ru);
    return double(ru.ru_maxrss) / 1024.0;
}

/// A CLI11 app for one subcommand: no generated help (csgv --help prints the usage the README
/// documents), unknown options collected rather than thrown (they get our message), and a value
/// given twice keeps the last, as the hand parsers did.
inline void configureCommand(CLI::App& app) {
    app.set_help_flag();
    app.allow_extras();
    app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
}

/// @brief Options whose values each command converts with its own code and messages, after
/// CLI11 has split the words: in command-line order, every occurrence (so a repeated option's
/// last value wins, and the first bad value on the line is the one reported).
class ValueOptions {
public:
    explicit ValueOptions(CLI::App& app) : m_app(app) {}

    /// An option that takes one value per occurrence.
    void add(const std::string& name, std::function<Status(const std::string&)> convert) {
        m_converters.emplace_back(m_app.add_option(name), std::move(convert));
    }

    Status convert() const {
        std::map<const CLI::Option*, size_t> seen;
        for (const CLI::Option* option : m_app.parse_order()) {
            for (const auto& [o, convert] : m_converters) {
                if (o != option) continue;
                const size_t k = seen[o]++;
                if (k < o->results().size())
                    if (Status s = convert(o->results()[k]); !s) return s;
            }
        }
        return Status::ok();
    }

private:
    CLI::App& m_app;
    std::vector<std::pair<const CLI::Option*, std::function<Status(const std::string&)>>> m_converters;
};

/// Parses the words after the command name (`argv[2..]`). `unknownSuffix` ends the message for
/// an unknown option (" for render").
inline Status parseCommand(CLI::App& app, int argc, char** argv, const std::string& unknownSuffix = "") {
    std::vector<std::string> words(argv + std::min(argc, 2), argv + argc);
    std::reverse(words.begin(), words.end()); // CLI11 consumes from the back
    try {
        app.parse(words);
    } catch (const CLI::ArgumentMismatch& e) {
        // "--level: 1 required TEXT missing": the wording the tool has always used.
        const std::string message = e.what();
        const size_t colon = message.find(": ");
        if (colon != std::string::npos && message.size() >= 7 && message.compare(message.size() - 7, 7, "missing") == 0)
            return Status::error("option " + message.substr(0, colon) + " needs a value");
        return Status::error(message);
    } catch (const CLI::ParseError& e) {
        std::string message = e.what();
        std::replace(message.begin(), message.end(), '\n', ' ');
        return Status::error(message);
    }
    for (const std::string& word : app.remaining())
        if (word.size() > 1 && word[0] == '-') return Status::error("unknown option '" + word + "'" + unknownSuffix);
    return Status::ok();
}

} // namespace csgv
