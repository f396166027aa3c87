// SPDX-License-Identifier: MIT
#pragma once
/// @file CommandLine.h
/// @brief The one command-line parser of `csgv` (CLI11) as every subcommand uses it: CLI11
/// splits the words (flags, options with values, `--name=value`, positionals), the commands
/// convert the values with their own messages, and every parse error is one line for
/// "csgv: error: ...".

#include "csgv/base/Status.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace csgv {

/// A CLI11 app for one subcommand: no generated help (csgv --help prints the usage the README
/// documents), unknown options collected rather than thrown (they get our message), and a value
/// given twice keeps the last, as the hand parsers did.
inline void configureCommand(CLI::App& app) {
    app.set_help_flag();
    app.allow_extras();
    app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
}

/// An option that may be repeated, one value per occurrence (`--attributes A --attributes B`).
inline CLI::Option* repeatedOption(CLI::App& app, const std::string& name, std::vector<std::string>& values) {
    return app.add_option(name, values)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
        ->allow_extra_args(false);
}

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
