// PCL reports its errors on the console; ttp reports its own (InputError,
// a refused datum), so PCL is kept quiet while it works (not part of the
// public API).
#pragma once

#include <pcl/console/print.h>

namespace ttp::inspect::internal {

class QuietPcl {
 public:
  QuietPcl() : level_(pcl::console::getVerbosityLevel()) {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  }
  ~QuietPcl() { pcl::console::setVerbosityLevel(level_); }
  QuietPcl(const QuietPcl&) = delete;
  QuietPcl& operator=(const QuietPcl&) = delete;

 private:
  pcl::console::VERBOSITY_LEVEL level_;
};

}  // namespace ttp::inspect::internal
