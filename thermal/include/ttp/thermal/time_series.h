// A TALC log (talc-log.md) as a thermal time series (thermal-log.md model):
// temperatures and speeds as inputs, the seven R-test errors as sparse
// outputs, so that the thermal error models and the replay run on TALC logs
// as on any thermal log.
#pragma once

#include "ttp/models/time_series.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::thermal {

// Inputs: T_env, T_ws, T_mwf, T_dT_cool (a difference, K), n_spindle
// (spindle_rpm), n_c (c_rpm), each held from its last logged value (rows
// before the first value take the first one); a column the log never fills
// is left out. Outputs (um), at each R-test's reference time (t_s - dur_s/2),
// relative to the first R-test: d_EX0C, d_EY0C, d_EZ0T, d_ER0T, and the
// angles as displacements at the R-test sphere's radius
// (sphere_distance_mm): d_EA0C_r, d_EB0C_r, d_EC0C_r = angle * radius.
// Rows: every sample row and every R-test reference time, in time order.
models::TimeSeries TalcLogToTimeSeries(const TalcLog& log);

// A thermal log (thermal-log.md) or a TALC log (talc-log.md, converted as
// above), told apart by a `talc-log` key among the leading `#` lines (a
// UTF-8 byte-order mark skipped). What `ttp thermal` and `ttp talc` read.
models::TimeSeries ReadThermalOrTalcLog(const std::string& path);

}  // namespace ttp::thermal
