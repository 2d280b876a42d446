#pragma once
// Conductivities by tissue name (AssembleFEMPoisson, ComputeLeadField).
//
// The literature table is the one SimNIBS uses by default (SimNIBS 4 documentation,
// "Conductivity values"; simnibs/simulation/cond.py, standard_cond), in S/m:
//   white matter 0.126, grey matter 0.275, CSF 1.654, bone 0.010 (compact bone 0.008, spongy bone
//   0.025), scalp 0.465, eyes 0.5, blood 0.6, muscle 0.16;
// and air 2.5e-14 (fair-weather air near the ground, 1e-14 .. 1e-13 S/m: an insulator; meshing
// the air and solving in it gives a badly conditioned system, which the solver reports).
// Names match case-insensitively with spaces, '-' and '_' alike, and through the aliases listed
// in TissueConductivity.cpp (e.g. "WM", "white", "Cerebral-White-Matter"; "skull" for bone; "skin"
// for scalp; SimNIBS's own names such as "Eye_balls").
//
// Where a label's conductivity comes from, first that applies:
//   "parameter"   the `conductivities` list (by label or by the tissue's name);
//   "label table" the mesh's own (TetMesh::materialConductivities, from a CSV/TSV label table);
//   "literature"  the table above, by the tissue's name (when `byName` is on);
//   "default"     `default_conductivity`.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/FEM/Conductivity.h"

namespace tetflow {

// The literature conductivity of a tissue name [S/m], and the table's name for it in *matched.
std::optional<double> literatureConductivity(const std::string& name, std::string* matched = nullptr);

// `conductivities` items in which the label may be a tissue name of the mesh ("CSF:1.79"): the
// names replaced by their labels. InputError naming the item and the mesh's names when a name is
// not one of them.
std::vector<std::string> conductivityItemsByLabel(const std::vector<std::string>& items,
                                                  const std::map<int32_t, std::string>& names);

// Fills `table` for every material of `mesh` that the parameter did not set, in the order above;
// returns each material's source ("parameter", "label table", "literature" or "default").
std::map<int32_t, std::string> completeConductivities(ConductivityTable& table, const TetMesh& mesh, bool byName);

} // namespace tetflow
