#include "HugePages.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace tetflow {

void useTransparentHugePages(char** argv) {
  const char* off = std::getenv("TETFLOW_NO_HUGEPAGES");
  if (off && *off && std::string(off) != "0") return;
  const char* current = std::getenv("GLIBC_TUNABLES");
  const std::string tunables = current ? current : "";
  if (tunables.find("glibc.malloc.hugetlb") != std::string::npos) return; // set (by us or the user)
  std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(mode, line) || line.find("[madvise]") == std::string::npos) return;
  const std::string value =
      tunables.empty() ? "glibc.malloc.hugetlb=1" : tunables + ":glibc.malloc.hugetlb=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // exec failed: carry on in this process, and do not leave the setting to child processes.
  if (current) setenv("GLIBC_TUNABLES", current, 1);
  else unsetenv("GLIBC_TUNABLES");
}

} // namespace tetflow
