// A synthetic program IR with every statement type, shared by the tests.
#pragma once

#include <cmath>
#include <random>

#include "ttp/gcode/program.h"

namespace ttp::gcode::testing {

inline Program EveryStatementProgram() {
  Program p;
  p.name = "sample";
  p.number = 1234;
  p.title = "every statement";
  auto& s = p.statements;
  s.push_back(Comment{"start"});
  s.push_back(TableClamp{false});
  s.push_back(ToolChange{1, "16 mm end mill"});
  s.push_back(SpindleOn{3000, true});
  s.push_back(Coolant{true});
  s.push_back(Rapid{{10.0, -20.5, 50.0, 0.0}});
  s.push_back(Rapid{{std::nullopt, std::nullopt, 2.0, std::nullopt}});
  s.push_back(Feed{{std::nullopt, std::nullopt, -1.0, std::nullopt}, 600});
  s.push_back(Feed{{30.25, -20.5, std::nullopt, std::nullopt}, 600});
  s.push_back(Feed{{std::nullopt, 5.125, std::nullopt, 15.5}, 450});
  s.push_back(Report{"cut", "Z5", 0.0});
  s.push_back(Dwell{2.5});
  s.push_back(SpindleOn{2500, false});
  s.push_back(SpindleOff{});
  s.push_back(Coolant{false});
  s.push_back(Rapid{{std::nullopt, std::nullopt, 50.0, 60.0}});
  s.push_back(TableClamp{true});
  s.push_back(Report{"cut", "X1-5", 60.0});
  s.push_back(TableClamp{false});
  s.push_back(Feed{{std::nullopt, std::nullopt, std::nullopt, 90.0}, 3600});
  s.push_back(CSpin{20});
  s.push_back(Dwell{30});
  s.push_back(CSpin{0});
  s.push_back(ToolChange{4, ""});
  s.push_back(SpindleOn{8000, true});
  s.push_back(Rapid{{-97.3, 0.0, -12.1, 30.0}});
  s.push_back(Report{"cut", "Y2-9", -30.0});
  s.push_back(SpindleOff{});
  s.push_back(ProgramEnd{});
  return p;
}

// A random program (fixed seed) mixing every statement type, with values
// that are not round numbers (the writers' formats round them).
inline Program RandomProgram(unsigned seed, int statements) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-150.0, 150.0);
  std::uniform_real_distribution<double> angle(-400.0, 400.0);
  std::uniform_real_distribution<double> feed(10.0, 5000.0);
  std::uniform_int_distribution<int> kind(0, 11);
  std::uniform_int_distribution<int> coin(0, 1);
  const auto maybe = [&](double v) {
    return coin(rng) ? std::optional<double>(v) : std::nullopt;
  };
  Program p;
  p.name = "random";
  p.title = "random " + std::to_string(seed);
  p.statements.push_back(ToolChange{1, ""});
  for (int i = 0; i < statements; ++i) {
    switch (kind(rng)) {
      case 0:
      case 1: {
        Axes a{pos(rng), maybe(pos(rng)), maybe(pos(rng)), maybe(angle(rng))};
        p.statements.push_back(Rapid{a});
        break;
      }
      case 2:
      case 3: {
        Axes a{maybe(pos(rng)), pos(rng), maybe(pos(rng)), maybe(angle(rng))};
        p.statements.push_back(Feed{a, feed(rng)});
        break;
      }
      case 4: {  // pure C feed, deg/min
        p.statements.push_back(Feed{
            {std::nullopt, std::nullopt, std::nullopt, angle(rng)}, feed(rng)});
        break;
      }
      case 5:
        p.statements.push_back(Dwell{feed(rng) / 100.0});
        break;
      case 6:
        if (coin(rng))
          p.statements.push_back(
              SpindleOn{std::round(feed(rng)), coin(rng) == 1});
        else
          p.statements.push_back(SpindleOff{});
        break;
      case 7:
        p.statements.push_back(Coolant{coin(rng) == 1});
        break;
      case 8:
        p.statements.push_back(
            CSpin{coin(rng) ? std::round(feed(rng) / 5) : 0});
        break;
      case 9:
        p.statements.push_back(TableClamp{coin(rng) == 1});
        break;
      case 10:
        p.statements.push_back(Report{"cut", "Z" + std::to_string(1 + i % 9),
                                      std::round(angle(rng) * 1000) / 1000});
        break;
      case 11:
        p.statements.push_back(Comment{"step " + std::to_string(i)});
        break;
    }
  }
  p.statements.push_back(ProgramEnd{});
  return p;
}

}  // namespace ttp::gcode::testing
