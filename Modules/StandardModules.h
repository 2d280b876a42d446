#pragma once
#include <optional>
// Registration of every TetFlow module. Dataflow never includes concrete modules: tools call this
// once to fill a registry.
#include "Algorithms/FEM/Conductivity.h"
#include "Algorithms/FEM/IterativeSolver.h"
#include "Algorithms/FEM/Meg.h"
#include "Algorithms/FEM/SourceModels.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Dataflow/ModuleRegistry.h"

namespace tetflow {

void registerStandardModules(ModuleRegistry& registry);

// One per module file.
void registerCreatePhantom(ModuleRegistry& r);
void registerReadLabelVolume(ModuleRegistry& r);
void registerWriteVolume(ModuleRegistry& r);
void registerReadMesh(ModuleRegistry& r);
void registerWriteMesh(ModuleRegistry& r);
void registerExtractSurfaces(ModuleRegistry& r);
void registerEvaluateQuality(ModuleRegistry& r);

void registerReadIndicatorFunctions(ModuleRegistry& r);
void registerGenerateBackgroundMesh(ModuleRegistry& r);
void registerComputeSizingField(ModuleRegistry& r);
void registerCleaveMesh(ModuleRegistry& r);
void registerAssembleFEMPoisson(ModuleRegistry& r);
void registerImproveMesh(ModuleRegistry& r);
void registerComputeLeadField(ModuleRegistry& r);
void registerAnalyticSphereEEG(ModuleRegistry& r);
void registerComputeMEG(ModuleRegistry& r);
void registerComputeMegLeadField(ModuleRegistry& r);
// CAD models (OpenCASCADE; without it they are registered but say so when run, with this).
void registerReadCADModel(ModuleRegistry& r);
void registerMeshCADSurface(ModuleRegistry& r);
[[noreturn]] void throwBuiltWithoutOpenCascade(const std::string& module);

// A parameter that names a label value or 'none' (empty = none); InputError naming the parameter,
// its value and `hint` (what to give instead) for anything else.
std::optional<int32_t> labelOrNoneParam(ExecutionContext& ctx, const std::string& name, const std::string& hint);

// "LabelVolume or Materials" inputs: a label volume becomes LabelMaterials (blendSigma voxels).
std::shared_ptr<const MaterialSet> materialsFromInput(const DataPtr& data, double blendSigma);

// Mesh improvement parameters shared by ImproveMesh and CleaveMesh (names prefixed there by
// "improve_"): min_angle, max_angle, max_volume_change, passes; and the log line when tets are left
// outside the target.
std::vector<ParamSpec> improveParamSpecs(const std::string& prefix);
ImproveParams improveParamsFrom(const ExecutionContext& ctx, const std::string& prefix);
void logUnfixed(ExecutionContext& ctx, const ImproveStats& s, const ImproveParams& p);

// Solver parameters shared by AssembleFEMPoisson and ComputeLeadField, in this order: solver,
// preconditioner, tolerance, max_iterations, solver_backend, petsc_options.
std::vector<ParamSpec> solverParamSpecs(const std::string& defaultSolver = "minres");
// conductivities, default_conductivity, conductivity_by_name (ConductivityParams.cpp).
std::vector<ParamSpec> conductivityParamSpecs();
// The conductivity table those give for `mesh`: labels or tissue names, then the mesh's label
// table, the literature by name and the default; each material's value, source and name are
// added to `report`.
ConductivityTable conductivitiesFrom(const ExecutionContext& ctx, const TetMesh& mesh, Report& report);
SolverParams solverParamsFrom(const ExecutionContext& ctx);
// `source_model` (partial_integration | venant | subtraction): how a dipole becomes a load
// (FEM/SourceModels.h), shared by AssembleFEMPoisson and the lead fields; subtraction only where
// it is offered.
ParamSpec sourceModelParamSpec(bool withSubtraction);
SourceModel sourceModelFrom(const ExecutionContext& ctx);
// The lead fields' sources and matrix file (ComputeLeadField, ComputeMegLeadField):
// source_labels, sources_file, filename (.npy/.csv).
std::vector<ParamSpec> leadFieldParamSpecs();
// The sources those give: labels and points (FEM/LeadField.h leadFieldSources checks them).
void leadFieldSourcesFrom(const ExecutionContext& ctx, std::vector<int32_t>& labels, std::vector<Vec3>& points);
// The MEG sensors (ComputeMEG, ComputeMegLeadField): sensors_file, sensor_unit_scale; and the
// sensors they give (InputError for an empty sensors_file).
std::vector<ParamSpec> megSensorParamSpecs();
std::vector<MegSensor> megSensorsFrom(const ExecutionContext& ctx);

// Shared helper: the Report figures of a label volume (dims, spacing, origin, labels, counts).
void reportLabelVolume(Report& report, const LabelVolume& v);
// A mesh made from a label volume takes the tissue names and conductivities of the labels it holds
// (nothing for other inputs, such as indicator functions).
void carryLabelNames(const DataPtr& labels, TetMesh& mesh);

} // namespace tetflow
