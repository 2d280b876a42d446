// ComputeSizingField: the sizing field of the material interfaces (seed §5.3,
// Algorithms/SizingField/SizingField.h) as a scalar volume in mm.
#include "Algorithms/SizingField/SizingField.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ComputeSizingField : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const auto mats = materialsFromInput(ctx.input(0), ctx.getDouble("blend_sigma"));
    SizingFieldParams p;
    p.sampling_rate = ctx.getDouble("sampling_rate");
    p.lipschitz = ctx.getDouble("lipschitz");
    p.feature_scaling = ctx.getDouble("feature_scaling");
    p.padding = static_cast<int>(ctx.getInt("padding"));
    p.min_size = ctx.getDouble("min_size");
    p.max_size = ctx.getDouble("max_size");
    SizingFieldResult r = computeSizingField(*mats, p, ctx.progress());
    writeSizingFieldReport(r, ctx.report());
    if (r.interfaceSamples == 0)
      ctx.log("no material interface in the volume: the sizing field is uniform");
    else if (r.medialSamples == 0)
      ctx.log("no medial samples found (no interface bounds a layer, tube or body whose medial "
              "surface the grid resolves): the feature size is the unbounded size; raise "
              "sampling_rate if a feature should have been seen");
    ctx.setOutput(0, makeData<ScalarVolumeData>(std::move(r.field)));
  }
};
} // namespace

void registerComputeSizingField(ModuleRegistry& r) {
  const SizingFieldParams d;
  ModuleInfo m;
  m.name = "ComputeSizingField";
  m.category = "Meshing";
  m.description =
      "Sizing field (seed §5.3): the local feature size of the material interfaces (distance to "
      "their medial surfaces, from two feature transforms) extended over the volume with growth "
      "limited to `lipschitz` mm per mm, then clamped to [min_size, max_size]. Output: element "
      "size in mm on a grid covering the volume's box.";
  m.inputs = {{"volume", {PortType::LabelVolume, PortType::Materials}, "labels or indicator functions"}};
  m.outputs = {{"sizing", {PortType::ScalarVolume}, "sizing field (mm)"}};
  ParamSpec pad = makeParam("padding", ParamType::Int, int64_t(d.padding), "samples",
                            "whole samples added around the grid on every side (they copy the "
                            "nearest in-grid sample)");
  pad.min = 0;
  pad.max = 1000;
  m.params = {
      doubleParam("sampling_rate", d.sampling_rate, 1e-3, 16.0, "",
                  "samples per voxel along each axis (0.5 = every other voxel, 2 = twice as fine)"),
      doubleParam("lipschitz", d.lipschitz, 1e-6, std::nullopt, "mm/mm",
                  "largest growth of the size per mm of distance"),
      doubleParam("feature_scaling", d.feature_scaling, 1e-6, std::nullopt, "",
                  "multiplies the local feature size"),
      pad,
      doubleParam("min_size", d.min_size, 0.0, std::nullopt, "mm", "lower clamp of the size (0 = none)"),
      doubleParam("max_size", d.max_size, 0.0, std::nullopt, "mm",
                  "upper clamp of the size (0 = none: the longest side of the box)"),
      doubleParam("blend_sigma", kDefaultBlendSigma, 0.05, 10.0, "voxels",
                  "smoothing of label volumes into indicator functions"),
  };
  m.summaryKeys = {"dims", "min_size_mm", "max_size_mm"};
  m.factory = [] { return std::make_unique<ComputeSizingField>(); };
  r.add(std::move(m));
}

} // namespace tetflow
