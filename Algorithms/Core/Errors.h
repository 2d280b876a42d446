#pragma once
// TetFlow error kinds. Algorithms throw exactly one of these, once; nothing aborts.
//   InputError       – the user can fix it (bad file, bad value, wrong parameter). The message
//                      names the culprit (file, line, parameter) and, where possible, the fix.
//   ProcessingError  – the algorithm failed on valid input (numerical breakdown, internal limit).
//   GateFailure      – a ProcessingError after the outputs were set: they are passed on.
//   Cancelled        – a progress sink asked to stop.
#include <stdexcept>
#include <string>

namespace tetflow {

class Error : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

class InputError : public Error {
public:
  using Error::Error;
};

class ProcessingError : public Error {
public:
  using Error::Error;
};

// A check the module was asked to make failed (EvaluateQuality's certificate or angle bounds),
// after the module computed its outputs: the outputs stand and go on downstream (the user gets the
// mesh, with its flags), the module and the run fail.
class GateFailure : public ProcessingError {
public:
  using ProcessingError::ProcessingError;
};

class Cancelled : public Error {
public:
  Cancelled() : Error("cancelled") {}
};

} // namespace tetflow
