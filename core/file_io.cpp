#include "core/file_io.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <mutex>
#include <set>
#include <sys/stat.h>
#include <unistd.h>

#include "core/errors.h"

namespace sm {
namespace {

namespace fs = std::filesystem;

/// What kind of file `st` describes, for messages.
const char* kind_of(const struct stat& st) {
  if (S_ISDIR(st.st_mode)) return "a directory";
  if (S_ISFIFO(st.st_mode)) return "a FIFO";
  if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return "a device";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  return "not a regular file";
}

// ---- Temporary files removed on SIGINT/SIGTERM/SIGHUP --------------------------------------
// The handler may only call async-signal-safe functions: it unlinks the paths held in fixed
// slots (no allocation), then re-raises the signal with its default action.
constexpr std::size_t kTempSlots = 64;
constexpr std::size_t kTempPathMax = 4096;
struct TempSlot {
  std::atomic<bool> used{false};
  char path[kTempPathMax];
};
std::array<TempSlot, kTempSlots> g_temp_slots;
std::mutex g_temp_mutex;

extern "C" void remove_temps_and_reraise(int sig) {
  for (TempSlot& s : g_temp_slots) {
    if (s.used.load(std::memory_order_acquire)) ::unlink(s.path);
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void install_signal_cleanup() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL) continue;  // someone else's
      struct sigaction sa {};
      sa.sa_handler = remove_temps_and_reraise;
      sigemptyset(&sa.sa_mask);
      ::sigaction(sig, &sa, nullptr);
    }
  });
}

/// Registers a temporary file for removal on a signal; returns its slot (or -1 when all are
/// taken: then only the next run's clean-up of leftovers removes it).
int register_temp(const fs::path& tmp) {
  install_signal_cleanup();
  const std::string s = tmp.string();
  if (s.size() >= kTempPathMax) return -1;
  std::lock_guard lock(g_temp_mutex);
  for (std::size_t i = 0; i < kTempSlots; ++i) {
    TempSlot& slot = g_temp_slots[i];
    if (slot.used.load(std::memory_order_relaxed)) continue;
    std::memcpy(slot.path, s.c_str(), s.size() + 1);
    slot.used.store(true, std::memory_order_release);
    return static_cast<int>(i);
  }
  return -1;
}

void unregister_temp(int slot) {
  if (slot < 0) return;
  std::lock_guard lock(g_temp_mutex);
  g_temp_slots[static_cast<std::size_t>(slot)].used.store(false, std::memory_order_release);
}

// ---- Leftovers of killed runs ---------------------------------------------------------------
/// True for ".NAME.EXT.tmpPID" with EXT one the tool writes and PID a process that no longer
/// exists (nor is this one).
bool is_stale_temp(const std::string& name) {
  if (name.size() < 3 || name[0] != '.') return false;
  const auto mark = name.rfind(".tmp");
  if (mark == std::string::npos || mark + 4 >= name.size()) return false;
  const std::string digits = name.substr(mark + 4);
  if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); })) {
    return false;
  }
  static const char* const ours[] = {"glb", "gltf", "obj", "ply", "json", "swc", "bin", "png", "txt"};
  const std::string target = name.substr(1, mark - 1);
  const std::string ext = extension_of(target);
  if (std::none_of(std::begin(ours), std::end(ours), [&](const char* e) { return ext == e; })) return false;
  const long pid = std::stol(digits);
  if (pid <= 0 || pid == ::getpid()) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

/// Removes the leftovers of killed runs from `dir`, once per directory and process.
void remove_stale_temps(const fs::path& dir) {
  static std::mutex m;
  static std::set<std::string> done;
  {
    std::lock_guard lock(m);
    if (!done.insert(dir.string()).second) return;
  }
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (is_stale_temp(name) && it->is_regular_file(ec)) fs::remove(it->path(), ec);
  }
}

// ---- Targets ---------------------------------------------------------------------------------
/// The file to replace for output `path`: `path` itself, or the file a symlink points to.
/// Throws IoError when the target exists but is not a regular file, or the link is dangling.
fs::path resolve_output(const fs::path& path) {
  struct stat lst {};
  if (::lstat(path.c_str(), &lst) != 0) {
    if (errno == ENOENT) return path;
    throw IoError("cannot write " + path.string() + ": " + std::strerror(errno));
  }
  if (S_ISLNK(lst.st_mode)) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
      throw IoError("cannot write " + path.string() + ": it is a symlink to nothing (" + std::strerror(errno) + ")");
    }
    if (!S_ISREG(st.st_mode)) {
      throw IoError("cannot write " + path.string() + ": it is a symlink to " + kind_of(st) +
                    ", not to a regular file; refusing to replace it");
    }
    std::error_code ec;
    const fs::path real = fs::canonical(path, ec);
    if (ec) throw IoError("cannot write " + path.string() + ": " + ec.message());
    return real;
  }
  if (!S_ISREG(lst.st_mode)) {
    throw IoError("cannot write " + path.string() + ": it is " + kind_of(lst) +
                  (S_ISDIR(lst.st_mode) ? "" : ", not a regular file; refusing to replace it"));
  }
  return path;
}

fs::path dir_of(const fs::path& path) {
  return path.has_parent_path() ? path.parent_path() : fs::path(".");
}

void check_writable_dir(const fs::path& dir, const fs::path& path) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    throw IoError("cannot write " + path.string() + ": directory " + dir.string() + " does not exist");
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    throw IoError("cannot write " + path.string() + ": directory " + dir.string() + " is not writable");
  }
}

}  // namespace

struct OutputTransaction::Pending {
  fs::path tmp, target;
  int slot;
};

namespace {
std::vector<OutputTransaction::Pending>* g_transaction = nullptr;  // the open OutputTransaction's list
}  // namespace

std::string read_file(const std::filesystem::path& path, std::uintmax_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw IoError("cannot open " + path.string() + ": " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw IoError("cannot read " + path.string() + ": it is a directory");
  if (!S_ISREG(st.st_mode)) throw IoError("cannot read " + path.string() + ": it is " + kind_of(st) + ", not a regular file");
  if (static_cast<std::uintmax_t>(st.st_size) > max_bytes) {
    throw IoError("cannot read " + path.string() + ": " + std::to_string(st.st_size) + " bytes, more than the limit of " +
                  std::to_string(max_bytes));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open " + path.string() + ": " + std::strerror(errno));
  std::string out;
  out.reserve(static_cast<std::size_t>(st.st_size));
  char buf[1 << 16];
  while (in) {
    in.read(buf, sizeof buf);
    const auto got = static_cast<std::size_t>(in.gcount());
    if (out.size() + got > max_bytes) {  // the file grew while being read
      throw IoError("cannot read " + path.string() + ": more than the limit of " + std::to_string(max_bytes) + " bytes");
    }
    out.append(buf, got);
  }
  if (in.bad()) throw IoError("cannot read " + path.string());
  return out;
}

void check_output_path(const std::filesystem::path& path) {
  if (path.empty()) throw IoError("cannot write: empty output path");
  const fs::path target = resolve_output(path);
  check_writable_dir(dir_of(target), path);
}

void check_output_dir(const std::filesystem::path& dir) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) throw IoError("cannot write into " + dir.string() + ": it is " + std::string(kind_of(st)) + ", not a directory");
    if (::access(dir.c_str(), W_OK | X_OK) != 0) throw IoError("cannot write into " + dir.string() + ": not writable");
    return;
  }
  const fs::path parent = fs::absolute(dir).parent_path();
  check_writable_dir(parent, dir);
}

void write_file_atomically(const std::filesystem::path& path, std::string_view contents) {
  write_file_atomically(path, [&](std::ostream& out) { out.write(contents.data(), static_cast<std::streamsize>(contents.size())); });
}

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& writer) {
  const fs::path target = resolve_output(path);
  const fs::path dir = dir_of(target);
  check_writable_dir(dir, path);
  remove_stale_temps(dir);
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  const int slot = register_temp(tmp);
  std::error_code ec;
  try {
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      if (!out) throw IoError("cannot write " + path.string() + ": " + std::strerror(errno));
      writer(out);
      out.flush();
      if (!out) throw IoError("cannot write " + path.string() + ": write failed (disk full?)");
    }
    if (g_transaction != nullptr) {
      // (Two outputs naming the same file: the later one wins, as without a transaction.)
      g_transaction->push_back({tmp, target, slot});
      return;
    }
    fs::rename(tmp, target, ec);
    if (ec) throw IoError("cannot write " + path.string() + ": " + ec.message());
    unregister_temp(slot);
  } catch (...) {
    fs::remove(tmp, ec);
    unregister_temp(slot);
    throw;
  }
}

OutputTransaction::OutputTransaction() : pending_(new std::vector<Pending>()) {
  if (g_transaction != nullptr) {
    delete pending_;
    throw InternalError("OutputTransaction: one is already open");
  }
  g_transaction = pending_;
}

OutputTransaction::~OutputTransaction() {
  std::error_code ec;
  for (const Pending& p : *pending_) {
    fs::remove(p.tmp, ec);
    unregister_temp(p.slot);
  }
  if (g_transaction == pending_) g_transaction = nullptr;
  delete pending_;
}

void OutputTransaction::commit() {
  g_transaction = nullptr;
  std::vector<Pending> files = std::move(*pending_);
  pending_->clear();
  for (std::size_t i = 0; i < files.size(); ++i) {
    std::error_code ec;
    fs::rename(files[i].tmp, files[i].target, ec);
    unregister_temp(files[i].slot);
    if (ec) {
      for (std::size_t k = i; k < files.size(); ++k) {
        fs::remove(files[k].tmp, ec);
        unregister_temp(files[k].slot);
      }
      throw IoError("cannot write " + files[i].target.string() + ": " + ec.message());
    }
  }
}

std::string extension_of(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace sm
