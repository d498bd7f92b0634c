// Timings of the gcode module: writing, reading and rs274-checking a long
// synthetic program (prints figures, never fails).
#include <chrono>
#include <cmath>
#include <iostream>

#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/gcode/writer.h"

using namespace ttp::gcode;

namespace {

// A facet-like zig-zag: n feed moves with C indexing and reports.
Program LongProgram(int moves) {
  Program p;
  p.name = "bench";
  p.title = "bench";
  p.statements.push_back(ToolChange{4, "finishing"});
  p.statements.push_back(SpindleOn{8000, true});
  for (int i = 0; i < moves; ++i) {
    const double c = std::fmod(i * 6.0, 360.0);
    p.statements.push_back(Rapid{{97.3, -10.0, 5.0, c}});
    p.statements.push_back(Feed{{97.3, 10.0, -12.1, std::nullopt}, 300});
    p.statements.push_back(Report{"cut", "X1-5", c});
  }
  p.statements.push_back(ProgramEnd{});
  return p;
}

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since)
      .count();
}

}  // namespace

int main() {
  const ttp::Config config;
  for (int moves : {1000, 20000}) {
    const Program p = LongProgram(moves);
    auto t0 = std::chrono::steady_clock::now();
    const std::string fanuc = WriteProgram(p, Dialect::kFanuc, config);
    const std::string ngc = WriteProgram(p, Dialect::kLinuxCnc, config);
    const double write_s = Seconds(t0);
    t0 = std::chrono::steady_clock::now();
    const auto ours = ReadProgram(ngc, Dialect::kLinuxCnc, config, "bench");
    const double read_s = Seconds(t0);
    std::cout << moves * 3 + 3 << " statements: write both " << write_s
              << " s (" << fanuc.size() + ngc.size() << " bytes), read "
              << read_s << " s (" << ours.size() << " canon), program time "
              << TotalDuration(ours) << " s\n";
    if (Rs274Available()) {
      t0 = std::chrono::steady_clock::now();
      const auto rs = RunRs274(ngc, config);
      const double rs_s = Seconds(t0);
      const auto d = CompareToolpaths(ours, rs.statements);
      std::cout << "  rs274 + parse " << rs_s
                << " s, same toolpath: " << (d.same ? "yes" : "no: " + d.what)
                << "\n";
    }
  }
}
