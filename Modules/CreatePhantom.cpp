// CreatePhantom: an exactly known label volume (Algorithms/Core/Phantom.h), so nets run with no
// input file.
#include "Algorithms/Core/Phantom.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class CreatePhantom : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    PhantomParams p;
    p.kind = phantomKindFromName(ctx.getString("kind"));
    p.voxel_size = ctx.getDouble("voxel_size");
    p.radius = ctx.getDouble("radius");
    p.skull_radius = ctx.getDouble("skull_radius");
    p.csf_radius = ctx.getDouble("csf_radius");
    p.brain_radius = ctx.getDouble("brain_radius");
    p.shell_thickness = ctx.getDouble("shell_thickness");
    p.margin = ctx.getDouble("margin");
    p.dims = static_cast<int>(ctx.getInt("dims"));
    ctx.progress().beginStage("voxelize");
    Phantom ph = makePhantom(p);
    ctx.progress().endStage();
    reportLabelVolume(ctx.report(), ph.volume);
    for (const auto& [label, vol] : ph.analyticVolumes())
      ctx.report().set("label_" + std::to_string(label) + "_analytic_mm3", ReportValue(vol));
    ctx.setOutput(0, makeData<LabelVolumeData>(std::move(ph.volume)));
  }
};
} // namespace

void registerCreatePhantom(ModuleRegistry& r) {
  const PhantomParams d;
  ModuleInfo m;
  m.name = "CreatePhantom";
  m.category = "DataIO";
  m.description =
      "Creates an exactly known label volume centred at the origin: a four-layer spherical head "
      "(1 scalp, 2 skull, 3 CSF, 4 brain), a sphere, two touching spheres, a thin shell around a "
      "core, or a sphere with a tiny isolated 7-voxel blob. Background label 0.";
  m.outputs = {{"volume", {PortType::LabelVolume}, "the phantom's labels"}};
  auto dbl = [](std::string n, double def, double min, std::string unit, std::string desc) {
    return doubleParam(std::move(n), def, min, std::nullopt, std::move(unit), std::move(desc));
  };

  ParamSpec kind;
  kind.name = "kind";
  kind.type = ParamType::Enum;
  kind.defaultValue = std::string("head");
  kind.choices = {"head", "sphere", "two_spheres", "shell", "blob"};
  kind.description = "which phantom";
  ParamSpec dims;
  dims.name = "dims";
  dims.type = ParamType::Int;
  dims.defaultValue = int64_t(0);
  dims.min = 0;
  dims.max = 4096;
  dims.unit = "voxels";
  dims.description = "voxels per axis; 0 = just enough for the shapes plus margin";
  m.params = {kind,
              dbl("voxel_size", d.voxel_size, 1e-6, "mm", "voxel edge length"),
              dbl("radius", d.radius, 1e-6, "mm", "outer radius (head: scalp; two_spheres: each)"),
              dbl("skull_radius", d.skull_radius, 1e-6, "mm", "head: outer radius of the skull"),
              dbl("csf_radius", d.csf_radius, 1e-6, "mm", "head: outer radius of the CSF"),
              dbl("brain_radius", d.brain_radius, 1e-6, "mm", "head: radius of the brain"),
              dbl("shell_thickness", d.shell_thickness, 1e-6, "mm", "shell: thickness of the shell"),
              dbl("margin", d.margin, 0, "mm", "background between the shapes and the box"),
              dims};
  m.summaryKeys = {"dims", "labels"};
  m.factory = [] { return std::make_unique<CreatePhantom>(); };
  r.add(std::move(m));
}

} // namespace tetflow
