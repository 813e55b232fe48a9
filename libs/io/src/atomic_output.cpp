#include "talus/io/atomic_output.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "talus/core/error.hpp"
#include "talus/core/log.hpp"

namespace talus::io {
namespace {

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "localhost";
  std::string host = name;
  for (char& c : host)
    if (c == '/' || c == '-') c = '_';
  return host;
}

// ".NAME.tmp-HOST-" : the temporaries of NAME, whatever the process.
std::string temp_prefix(const std::filesystem::path& final_path) {
  return "." + final_path.filename().string() + ".tmp-";
}

}  // namespace

std::string write_cause() {
  return errno != 0 ? " (" + std::string(std::strerror(errno)) + ")" : std::string();
}

std::size_t remove_stale_temporaries(const std::string& final_path) {
  namespace fs = std::filesystem;
  const fs::path p(final_path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  const std::string mine = temp_prefix(p) + host_name() + "-";
  std::size_t removed = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(mine, 0) != 0) continue;
    const std::string pid_text = name.substr(mine.size());
    if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos) continue;
    const auto pid = static_cast<pid_t>(std::stol(pid_text));
    // Only a process of this host that is gone: another host's temporary may be in use.
    if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;
    if (fs::remove(entry.path(), ec)) {
      ++removed;
      core::log_info("removed " + entry.path().string() + ", left by an interrupted run");
    }
  }
  return removed;
}

AtomicOutput::AtomicOutput(std::string final_path) : final_path_(std::move(final_path)) {
  const std::filesystem::path p(final_path_);
  if (p.filename().empty()) throw core::UsageError("output path '" + final_path_ + "' names no file");
  const auto dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(dir))
    throw core::RuntimeError(final_path_ + ": output directory does not exist");
  remove_stale_temporaries(final_path_);
  temp_path_ = (dir / (temp_prefix(p) + host_name() + "-" + std::to_string(::getpid()))).string();
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) std::remove(temp_path_.c_str());
}

void AtomicOutput::commit() {
  std::error_code ec;
  std::filesystem::rename(temp_path_, final_path_, ec);
  if (ec) throw core::RuntimeError(final_path_ + ": cannot write output (" + ec.message() + ")");
  committed_ = true;
}

std::string lock_path(const std::string& output) { return output + ".lock"; }

OutputLock::OutputLock(const std::string& output) : path_(lock_path(output)) {
  // A lock file unlinked by its holder between our open and flock locks nothing: retry.
  for (int attempt = 0; attempt < 100; ++attempt) {
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw core::RuntimeError(path_ + ": cannot create the lock file (" + std::strerror(errno) + ")");
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int why = errno;
      char holder[128] = {};
      const ssize_t n = ::pread(fd_, holder, sizeof holder - 1, 0);
      ::close(fd_);
      fd_ = -1;
      if (why != EWOULDBLOCK)
        throw core::RuntimeError(path_ + ": cannot lock (" + std::strerror(why) + ")");
      std::string who = n > 0 ? std::string(holder, static_cast<std::size_t>(n)) : std::string("unknown");
      while (!who.empty() && (who.back() == '\n' || who.back() == ' ')) who.pop_back();
      throw core::RuntimeError(output + ": another process (" + who + ") is writing this output and holds " + path_ +
                               "; wait for it to end or choose another -o");
    }
    struct stat opened{}, named{};
    if (::fstat(fd_, &opened) == 0 && ::stat(path_.c_str(), &named) == 0 && opened.st_ino == named.st_ino &&
        opened.st_dev == named.st_dev) {
      const std::string me = "pid " + std::to_string(::getpid()) + " on " + host_name() + "\n";
      if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, me.data(), me.size(), 0) < 0) {
        // The lock holds without its note; the note only helps the message of a second writer.
      }
      return;
    }
    ::close(fd_);
    fd_ = -1;
  }
  throw core::RuntimeError(path_ + ": cannot lock (the lock file keeps changing)");
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());
  ::close(fd_);
}

void write_text_file(const std::string& path, const std::string& text) {
  AtomicOutput out(path);
  {
    errno = 0;
    std::ofstream file(out.temp_path(), std::ios::binary);
    file << text;
    // close() writes what is buffered: a full disk shows only then.
    file.close();
    if (!file) throw core::RuntimeError(path + ": cannot write output" + write_cause());
  }
  out.commit();
}

}  // namespace talus::io
