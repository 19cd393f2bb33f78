#include "apps/common/huge_pages.h"

#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#if defined(__linux__) && defined(__GLIBC__)
#include <malloc.h>
#include <unistd.h>
#endif

namespace sm {

namespace {
constexpr const char* kDone = "STRANDMESH_HUGE_PAGES_SET";
}  // namespace

bool running_with_huge_pages() { return std::getenv(kDone) != nullptr; }

void reexec_with_huge_pages(char** argv) {
#if defined(__linux__) && defined(__GLIBC__)
  constexpr const char* kTunable = "glibc.malloc.hugetlb=1";
  if (argv == nullptr || argv[0] == nullptr) return;
  if (const char* opt = std::getenv("STRANDMESH_HUGE_PAGES"); opt != nullptr && std::string(opt) == "0") return;
  if (std::getenv(kDone) != nullptr) return;  // this is the re-executed process
  const char* user_tunables = std::getenv("GLIBC_TUNABLES");
  std::string tunables = user_tunables != nullptr ? user_tunables : "";
  if (tunables.find("glibc.malloc.hugetlb") != std::string::npos) return;  // the user chose
  {
    std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string mode;
    if (!thp || !std::getline(thp, mode) || mode.find("[never]") != std::string::npos) return;
  }
  tunables = tunables.empty() ? std::string(kTunable) : tunables + ":" + kTunable;
  if (setenv("GLIBC_TUNABLES", tunables.c_str(), 1) != 0 || setenv(kDone, "1", 1) != 0) return;
  // The program's own path (readlink rather than exec of /proc/self/exe itself: tools that run
  // the program, such as valgrind, report the program's path there, not their own).
  std::string self(4096, '\0');
  const ssize_t n = readlink("/proc/self/exe", self.data(), self.size() - 1);
  if (n > 0 && static_cast<std::size_t>(n) < self.size() - 1) {
    self.resize(static_cast<std::size_t>(n));
    execv(self.c_str(), argv);
  }
  // Only reached when exec failed: run on without huge pages.
  unsetenv(kDone);
#else
  (void)argv;
#endif
}

void keep_freed_memory() {
#if defined(__linux__) && defined(__GLIBC__)
  if (const char* opt = std::getenv("STRANDMESH_HUGE_PAGES"); opt != nullptr && std::string(opt) == "0") return;
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());  // mallopt takes an int: 2 GiB
#endif
}

}  // namespace sm
