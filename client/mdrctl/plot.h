// --plot DIR: PNG plots of a run with gnuplot (hysteresis loop F_x over ux, F_x and F_N over the
// step, the energy and the work of F_x per cycle, an interface's contact counts over the step,
// the profiles recorded at hold points, tractions and Jäger weights where recorded).
#pragma once

#include <string>

#include "mdr/base/status.h"
#include "mdr/v1/scene_file.pb.h"

namespace mdrctl {

// Whether gnuplot is on PATH.
bool GnuplotInstalled();
// OK when gnuplot is on PATH; otherwise an error saying so (checked before a run starts).
mdr::Status CheckGnuplot();
// `text` as a gnuplot single-quoted string.
std::string GnuplotQuoted(const std::string& text);
// Runs gnuplot on a script file; `option` names the command-line option in the error.
mdr::Status RunGnuplot(const std::string& script_file, const std::string& option);

// Writes the data files, the gnuplot script and the PNGs into dir (created if missing); returns
// the PNG paths written.
mdr::Result<std::vector<std::string>> WritePlots(const mdr::v1::RunReport& report,
                                                 const std::string& dir);

}  // namespace mdrctl
