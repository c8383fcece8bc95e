#include "Memory.h"

#include <malloc.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

namespace bench {

namespace {

int64_t highestPeakSeen = 0;

// A "Name:   1234 kB" line of /proc/self/status, in bytes.
int64_t statusBytes(const std::string& text, const std::string& name) {
  const size_t at = text.find(name + ":");
  if (at == std::string::npos) return 0;
  std::istringstream line(text.substr(at + name.size() + 1));
  int64_t kilobytes = 0;
  line >> kilobytes;
  return kilobytes * 1024;
}

}  // namespace

Rss readRss() {
  std::ifstream file("/proc/self/status");
  std::stringstream text;
  text << file.rdbuf();
  Rss rss{statusBytes(text.str(), "VmRSS"), statusBytes(text.str(), "VmHWM")};
  highestPeakSeen = std::max(highestPeakSeen, rss.peak);
  return rss;
}

int64_t processPeakRss() { return std::max(highestPeakSeen, readRss().peak); }

MemoryProbe::MemoryProbe() {
  readRss();  // keeps the peak so far before the reset drops it
  malloc_trim(0);
  std::ofstream("/proc/self/clear_refs") << "5";  // resets VmHWM to VmRSS (Linux >= 4.0)
  m_start = readRss().current;
}

MemoryProbe::Growth MemoryProbe::growth() const {
  const Rss now = readRss();
  return {now.current - m_start, now.peak - m_start};
}

}  // namespace bench
