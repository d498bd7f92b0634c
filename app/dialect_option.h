// The --dialect option of commands that read a program: fanuc, linuxcnc or
// auto (recognised from the program text).
#pragma once

#include <string>

#include "ttp/gcode/program.h"
#include "ttp/gcode/reader.h"

namespace ttp::app {

inline gcode::Dialect ChooseDialect(const std::string& name,
                                    const std::string& text,
                                    const std::string& source) {
  return name == "auto" ? gcode::ResolveDialect(text, source)
                        : gcode::ParseDialect(name, "--dialect");
}

}  // namespace ttp::app
