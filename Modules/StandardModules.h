#pragma once
// Registration of every TetFlow module. Dataflow never includes concrete modules: tools call this
// once to fill a registry.
#include "Dataflow/ModuleRegistry.h"

namespace tetflow {

void registerStandardModules(ModuleRegistry& registry);

// One per module file.
void registerCreatePhantom(ModuleRegistry& r);
void registerReadLabelVolume(ModuleRegistry& r);
void registerWriteVolume(ModuleRegistry& r);
void registerReadMesh(ModuleRegistry& r);
void registerWriteMesh(ModuleRegistry& r);
void registerEvaluateQuality(ModuleRegistry& r);

void registerReadIndicatorFunctions(ModuleRegistry& r);
void registerGenerateBackgroundMesh(ModuleRegistry& r);
void registerComputeSizingField(ModuleRegistry& r);
void registerCleaveMesh(ModuleRegistry& r);
void registerAssembleFEMPoisson(ModuleRegistry& r);

// "LabelVolume or Materials" inputs: a label volume becomes LabelMaterials (blendSigma voxels).
std::shared_ptr<const MaterialSet> materialsFromInput(const DataPtr& data, double blendSigma);

// Shared helper: the Report figures of a label volume (dims, spacing, origin, labels, counts).
void reportLabelVolume(Report& report, const LabelVolume& v);

} // namespace tetflow
