// SPDX-License-Identifier: MIT
#pragma once
/// @file FileUtil.h
/// @brief Atomic file output (temporary name, then rename), whole-file input, and the one stream
/// reader of plain and gzip files that every input format reads through.

#include "csgv/base/Status.h"

#include <csignal>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace csgv {

/// The text of the last system error (errno), for messages that name a file.
std::string errnoText();
/// A name beside `path` unique to this process and call (`path.tmp-PID-N`), for files written
/// and then renamed or removed; `.tmp-` names are what .gitignore and cleanup tests know.
std::string temporaryNameFor(const std::string& path);
/// Remembers a temporary file of this process (temporaryNameFor() remembers every name it hands
/// out), so that removeTemporaries() can take away what an interrupted process leaves.
void registerTemporary(const std::string& path);
/// Removes every remembered temporary that still exists (a renamed one is no longer there), with
/// SQLite's `-journal` beside it: what a tool's interrupt watchdog calls before it ends the
/// process, so that an interrupt leaves no partial output. Not async-signal-safe.
void removeTemporaries();
/// For a host process whose own handlers end it on SIGINT or SIGTERM (ParaView's pvbatch, pvpython
/// and GUI, whose logger prints a stack and aborts), or SIGHUP's default action (a terminal
/// closed): puts a handler before theirs, once, that
/// removes this process's temporaries (without waiting for a lock: a set being renamed into place
/// is given a moment, never more) and then hands the signal on as it was. A tool with its own
/// interrupt handling (csgv's interrupt::Guard) does not call it. Found by an attack pass: Ctrl-C
/// in pvbatch while the CSGV writer ran left its temporaries beside the output.
void removeTemporariesOnSignals();
/// Whether the signal is ignored now (SIG_IGN: `nohup`'s SIGHUP, a background job's SIGINT): a
/// handler installed for it would undo what the process was started with.
bool signalIgnored(int sig);
/// @brief Held while a set of files is renamed into place (publishVolumeFiles, publishTogether:
/// renames only, of microseconds; the old files a set replaces are removed after it). A tool's
/// interrupt watchdog takes it before removeTemporaries() and keeps it until it ends the process,
/// so an interrupt never lands between one set's renames (which would leave a new sidecar beside
/// the old volume). The holding thread does not take SIGINT, SIGTERM or SIGHUP meanwhile: another thread
/// takes them, or this one once the hold ends (a handler run on the thread that holds the lock
/// could not wait for it: Ctrl-C in pvpython left the old volume beside the new one as
/// '<name>.tmp-...-old', once in six saves of test_writer_interrupt.py). Start no thread inside a
/// hold: it would keep the signals blocked.
class [[nodiscard]] PublishingHold {
public:
    PublishingHold();
    ~PublishingHold() = default; ///< the lock first, then the signals (one that came meanwhile finds it free)
    PublishingHold(const PublishingHold&) = delete;
    PublishingHold& operator=(const PublishingHold&) = delete;

private:
    /// SIGINT, SIGTERM and SIGHUP blocked in this thread while it lives; unblocks those it blocked.
    struct SignalBlock {
        SignalBlock();
        ~SignalBlock();
        SignalBlock(const SignalBlock&) = delete;
        SignalBlock& operator=(const SignalBlock&) = delete;
        sigset_t added; ///< the signals that were not blocked before
    };
    SignalBlock m_signals; ///< made before the lock, given up after it
    std::unique_lock<std::mutex> m_lock;
};
/// @brief Exclusive flock()s on the folders of `paths` (each once, in order) while a set is renamed
/// into them: another process publishing there waits, so two writers of one name never leave a
/// mix of their sets (two `csgv compress` runs of one output left one's metadata beside the other's
/// volume, both exiting 0: 5 of 500 runs in an attack pass). A folder that cannot be locked (a file
/// system without flock), or one still locked after 2 s, is published into without it.
class FolderLocks {
public:
    explicit FolderLocks(const std::vector<std::string>& paths);
    ~FolderLocks();
    FolderLocks(const FolderLocks&) = delete;
    FolderLocks& operator=(const FolderLocks&) = delete;

private:
    std::vector<int> m_fds;
};
/// The hold (returned in place: `const PublishingHold held = holdPublishing();`).
PublishingHold holdPublishing();
/// Asked inside a hold before the first rename of a set or file: an error where the `csgv` tool was
/// interrupted (cancelRequested, Cancel.h), so that what finished writing after Ctrl-C is not
/// published while the tool says it wrote nothing.
Status interruptedBeforePublishing();
/// Seeks a C file to a 64-bit offset; false on failure (errno says why).
bool seekTo(std::FILE* f, uint64_t offset);

/// `message` with every `from` (a temporary a writer used) replaced by `to` (the name the user
/// knows).
std::string renamedInMessage(std::string message, const std::string& from, const std::string& to);
/// Whether an output may take the name `path`: it names nothing yet, or a regular file the user
/// may write. Refused, with a message naming it: a device, FIFO, folder or socket (the rename
/// that publishes an output would replace it by a file: `csgv render x.csgv /dev/null` as root
/// replaced the system's /dev/null), a symbolic link (the rename would replace the link and leave
/// the file it points to as it was) and a write-protected file: one the user may not write, or
/// one without any write bit, which protects it from root too (as rm asks before removing it).
/// Every publishing rename checks its target with this first.
Status replaceableOutput(const std::string& path);
/// Gives the temporary `tmp` the permission bits (and group, where allowed) of the regular file
/// `target` it is about to replace; nothing when there is none.
void keepModeOf(const std::string& target, const std::string& tmp);

/// Renames each written temporary (`first`) over its target (`second`) under holdPublishing(), so
/// an interrupt never lands inside the set: every target is checked (replaceableOutput) before
/// the first rename, and each keeps the permission bits of the file it replaces. On a failure the
/// temporaries not yet renamed are removed and the error names the targets already replaced.
Status publishTogether(const std::vector<std::pair<std::string, std::string>>& written);

/// @brief Writes to `<path>.tmp-<pid>-<n>` beside the target and renames it into place on
/// commit(); destroying it uncommitted removes the temporary, so a failure never leaves a half
/// file under the target name.
/// The target must be replaceableOutput() when opened and again when committed (what may replace
/// it is checked before anything is written); a file it replaces keeps its permission bits.
class AtomicFile {
public:
    AtomicFile() = default;
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    Status open(const std::string& path);
    Status write(const void* data, size_t bytes);
    /// Flushes, closes and renames over the target path.
    Status commit();
    void discard();

private:
    std::string m_path;
    std::string m_tmp;
    std::FILE* m_file = nullptr;
};

/// @brief Reads a file front to back in bounded chunks, inflating gzip on the fly, so that no input
/// format holds a whole compressed file or writes its own zlib loop.
///
/// `Auto` inflates when the content (from `offset`) starts with the gzip magic and passes other
/// content through (what zlib's gzopen does: `.nii.gz`, `.vraw.gz`); bytes after the last gzip
/// member are ignored, as gzread does. `Plain` never inflates (NRRD raw data may start with any
/// bytes). `Inflate` always inflates, gzip or zlib (NRRD's gzip encoding). Concatenated gzip
/// members are followed. A stream cut short just ends: callers see fewer bytes than they asked
/// for and word the truncation themselves.
class InputStream {
public:
    enum class Mode { Auto, Plain, Inflate };
    /// Which step failed, so that each format keeps its own wording.
    enum class Failure { None, Open, Read, Corrupt };

    InputStream();
    ~InputStream();
    InputStream(const InputStream&) = delete;
    InputStream& operator=(const InputStream&) = delete;

    /// Opens `path` and positions it at byte `offset` of the file (before any inflating).
    Status open(const std::string& path, Mode mode = Mode::Auto, uint64_t offset = 0);
    /// Continues on an already opened C file from its current position; the caller keeps
    /// ownership of `file` (NRRD reads its header and skips lines first).
    Status attach(std::FILE* file, const std::string& path, Mode mode);
    /// Reads up to `bytes`; fewer only at the end of the content. On an error, failure() says
    /// which step failed and the Status carries zlib's or the system's reason only.
    Result<size_t> read(void* out, size_t bytes);
    /// Discards up to `bytes` of content; returns how many were discarded.
    Result<uint64_t> skip(uint64_t bytes);
    /// Inflates on to the end of the current gzip member, so that its checksum is verified even
    /// when the caller needed fewer bytes than it holds; a checksum that does not match is an
    /// error (Failure::Corrupt), a member cut before its checksum is not (gzread's rule).
    /// Plain content: nothing to check.
    Status checkMemberEnd();
    /// An upper bound of the content still to come, from the file's size (deflate expands at most
    /// 1032:1), so that readers can reserve memory for what a file can hold, not for what its
    /// header claims.
    uint64_t remainingBound() const;
    /// Bytes of content delivered or skipped so far.
    uint64_t position() const { return m_position; }
    bool compressed() const { return m_inflating; }
    Failure failure() const { return m_failure; }

private:
    Status start(Mode mode);
    /// Moves unread input to the front and reads more; false at the end of the file.
    Result<bool> fill();
    Status fail(Failure f, const std::string& why);
    Result<size_t> inflateSome(uint8_t* out, size_t bytes);

    std::string m_path;
    std::FILE* m_file = nullptr;
    bool m_ownsFile = false;
    bool m_inflating = false;
    bool m_autoMode = true;
    bool m_memberEnded = false;
    bool m_inputEnded = false;
    bool m_finished = false;
    bool m_stopAtMemberEnd = false;
    Failure m_failure = Failure::None;
    uint64_t m_position = 0;
    uint64_t m_fileBytes = 0;
    std::vector<uint8_t> m_in;
    size_t m_inAt = 0;
    size_t m_inEnd = 0;
    struct Zlib; // zlib's state, kept out of this header
    std::unique_ptr<Zlib> m_zlib;
};

/// Size of a regular file, or an error naming the path.
Result<uint64_t> fileSize(const std::string& path);
/// Reads a whole file, refusing files larger than maxBytes.
Result<std::vector<uint8_t>> readFile(const std::string& path, uint64_t maxBytes);
/// Reads a whole file, transparently inflating gzip (`.gz`) content (through InputStream);
/// refuses more than maxBytes.
Result<std::vector<uint8_t>> readFileMaybeGz(const std::string& path, uint64_t maxBytes);
/// True when the path names an existing file.
bool fileExists(const std::string& path);
/// True when the path names something that exists and is not a regular file: a folder, FIFO,
/// device or socket (a FIFO's open waits for a writer, a device may never end). Found by stat
/// alone, nothing is opened.
bool existsButNotRegular(const std::string& path);
/// "a FIFO (named pipe)", "a folder", "a socket", "a device": what a stat's mode names, for
/// anything but a regular file.
std::string fileKind(unsigned mode);
/// "a FIFO (named pipe)", "a folder", "a dangling symbolic link"...: what `path` is when it is
/// not a regular file (symbolic links followed); empty for a regular file; "missing" when
/// nothing is there. By stat alone: nothing is opened.
std::string notRegularFile(const std::string& path);
/// Ok for an existing regular file, else notRegularFile in a sentence: "cannot open 'P': no such
/// file", "'P' is a FIFO (named pipe), not a file".
Status regularFile(const std::string& path);
/// The memory available now (MemAvailable of /proc/meminfo) in bytes; 0 where unknown.
uint64_t availableMemoryBytes();
/// True when `s` ends with `suffix` (lowercase ASCII), ignoring case: file extensions.
bool endsWithNoCase(const std::string& s, const char* suffix);

} // namespace csgv
