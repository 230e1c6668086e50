// PNG plots of the loop analysis reports (mdrctl loops --report, mdrctl fit --report), drawn by
// gnuplot from data files in a temporary directory that is removed afterwards: the report
// directory holds only the PNGs next to report.md and report.json.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/v1/analysis.pb.h"
#include "report_format.h"

namespace mdrctl {

// One run as the plots see it: a tangential record's F_x over u, or a torsional one's M over phi
// (labels).
struct PlottedSet {
  std::string label;
  const mdr::v1::LoopSamples* samples = nullptr;
  const mdr::v1::AnalyzeLoopsResponse* analysis = nullptr;
  double normal_force = 0;                     // N; NaN if unknown
  const std::vector<double>* model = nullptr;  // F_x (M) of the fitted scene per sample, or none
  std::size_t first_counted = 0;               // the first sample the fit counts
  const mdr::v1::SetFit* fit = nullptr;        // what the fit found in it, or none
  ChannelLabels labels;
};

// loop.png (F_x over u, or M over phi, coloured by cycle) and cycles.png (the figures per cycle),
// each name after `prefix` (one run of several: "run2_"). Returns the PNGs' file names (in dir).
mdr::Result<std::vector<std::string>> WriteLoopsPlots(const PlottedSet& set, const std::string& dir,
                                                      const std::string& prefix = "");

// loops.png (measured and fitted loops per set), residuals.png (a panel per set: the residuals
// over the counted samples, +-2 standard deviations of the force sensor's noise, the set's
// adequacy in the title) and, with a map (not for a torsional campaign), fretting_map.png
// (Q*/P against the actuator amplitude: the map's loops, the onsets, the measured cycles) and
// fretting_regimes.png (normal force against actuator amplitude: the boundary, the map's regimes,
// the measured cycles).
mdr::Result<std::vector<std::string>> WriteFitPlots(const std::vector<PlottedSet>& sets,
                                                    const mdr::v1::FrettingMapResponse* map,
                                                    const std::string& dir);

}  // namespace mdrctl
