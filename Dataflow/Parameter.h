#pragma once
// Typed module parameters (DESIGN §3): the registry declares a ParamSpec per parameter; networks
// hold ParamValues merged over the defaults. Values cross files and the command line as text:
//   bool    "true"/"false" (also 1/0, yes/no, on/off on input)
//   int     decimal integer
//   double  shortest text that reads back to the same double (so save->load->save is exact)
//   string  as is; `kind` Path marks file names (relative ones resolve against the .srn folder)
//   enum    one of `choices` (the saved name, never an index)
//   list    items separated by ';' (whitespace around items ignored), e.g. "1:0.33; 2:0.0042"
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace tetflow {

enum class ParamType : int { Bool = 0, Int = 1, Double = 2, String = 3, Enum = 4, List = 5 };
const char* paramTypeName(ParamType t);

using ParamValue = std::variant<bool, int64_t, double, std::string, std::vector<std::string>>;

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::Double;
  ParamValue defaultValue = 0.0;
  std::optional<double> min, max;    // inclusive bounds for Int/Double
  std::vector<std::string> choices;  // Enum
  std::string unit;                  // "mm", "S/m", "" ...
  std::string description;           // one line
  bool isInputPath = false;          // String/List holding input file names
  bool isOutputPath = false;         // String holding an output file name
};

// Parse text into a value of spec's type, checking range / choices. On failure returns nullopt
// and sets `error` to a message naming the problem and what is allowed (not the parameter name;
// callers prefix module id and parameter).
std::optional<ParamValue> parseParam(const ParamSpec& spec, const std::string& text,
                                     std::string& error);
// Canonical text of a value (what .srn files and `describe` show).
std::string formatParam(const ParamSpec& spec, const ParamValue& value);
// Check a value already typed (e.g. set from the GUI): right type, in range, valid choice.
bool checkParam(const ParamSpec& spec, const ParamValue& value, std::string& error);
// "0.2 (double, >= 0, mm)" style description of what is allowed, for messages and `describe`.
std::string describeAllowed(const ParamSpec& spec);

// A parameter declaration in one call (module registration); ranges and choices are set on the
// result where needed.
ParamSpec makeParam(std::string name, ParamType type, ParamValue def, std::string unit,
                    std::string description);
// A double parameter with optional inclusive bounds.
ParamSpec doubleParam(std::string name, double def, std::optional<double> min,
                      std::optional<double> max, std::string unit, std::string description);

std::string formatDouble(double v); // shortest round-trip text
std::vector<std::string> splitList(const std::string& text);

} // namespace tetflow
