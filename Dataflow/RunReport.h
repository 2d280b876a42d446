#pragma once
// Machine-readable record of one execution: every module's status, time, stage times, messages,
// error and Report, as JSON (what `tetflow run --report out.json` writes).
#include <string>

#include "Executor.h"

namespace tetflow {

std::string jsonEscape(const std::string& s);
std::string executionReportJson(const std::string& networkFile, const Network& net,
                                const Executor& exec, const Executor::Summary& summary);

} // namespace tetflow
