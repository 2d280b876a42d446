#include "CleavePipeline.h"

namespace tetflow {

namespace {
// A further local round's counts added to the first's (the forbidden faces after are the last's).
void addLocalRepair(LabelRepairStats& into, const LabelRepairStats& more) {
  into.contactTets += more.contactTets;
  into.unresolvedTets = more.unresolvedTets;
  into.pointContacts += more.pointContacts;
  into.pointTets += more.pointTets;
  into.closedEdges += more.closedEdges;
  into.edgeTets += more.edgeTets;
  into.relabelledVolume += more.relabelledVolume;
  into.forbiddenFacesAfter = more.forbiddenFacesAfter;
  into.forbiddenAreaAfter = more.forbiddenAreaAfter;
}
} // namespace

CleavePipelineResult cleavePipeline(const BackgroundMesh& bg, const MaterialSet& mats, const CleavePipelineParams& p,
                                    Progress& progress) {
  CleavePipelineResult out;
  CleaveParams cp = p.cleave;
  cp.strip_exterior.reset(); // stripped after the repair, below
  const auto argmaxShared = mats.sharedDominantLabels();
  const LabelVolume& argmax = *argmaxShared;
  // The label stripped below is not cleaved where it is deep in its exterior (CleaveParams::
  // cull_exterior): those tets would be output as they are and then stripped. Not with volume
  // calibration, whose repeated cleaves and repairs compare whole meshes.
  std::optional<ExteriorTest> exterior;
  if (p.strip && p.cull && p.calibration_rounds == 0) {
    progress.beginStage("exterior components");
    exterior.emplace(argmax, StripParams{*p.strip, p.stripCavities}, progress);
    cp.cull_exterior = *p.strip;
    cp.cull_exterior_at = [&exterior](const Vec3& x) { return (*exterior)(x); };
  }
  CleaveResult& r = out.cleaved;
  r = p.calibration_rounds > 0 ? cleaveCalibrated(bg, mats, cp, p.calibration_rounds, p.repair ? &p.repairParams : nullptr,
                                                  progress, out.calibration, out.calibrated)
                               : cleave(bg, mats, cp, progress);
  const MaterialSet& used = out.calibrated ? static_cast<const MaterialSet&>(*out.calibrated) : mats;
  auto refresh = [&] { // the per-material figures after a step
    const std::vector<MaterialTally> now = tallyMaterials(r.mesh, mats.labels());
    for (size_t i = 0; i < r.materials.size(); ++i) {
      r.materials[i].tets = now[i].tets;
      r.materials[i].meshVolume = now[i].volume;
    }
  };
  exterior.reset();
  const TetJoins* joins = r.exteriorJoins.empty() ? nullptr : &r.exteriorJoins;
  // The mesh's face neighbours once a step has computed them: the repair relabels, the stripping
  // renumbers them with the tets it keeps, the correction moves vertices; none changes which tets
  // share a face.
  std::vector<int32_t> faceNeighbours;
  if (p.repair) {
    // The image's components only when the repair has something to do (labelRepairNeeded).
    progress.beginStage("repair check");
    LabelContactOracle oracle(argmax); // the image's contacts, scanned for only when needed
    LabelRepairCheck check = checkLabelRepair(r.mesh, oracle, progress, joins);
    const auto& contacts = check.needed() ? oracle.all() : std::vector<std::pair<int32_t, int32_t>>{};
    progress.endStage();
    bool whole = check.extraPieces; // the whole repair, below
    if (!whole) { // only around the vertices the check found (nothing when none)
      // Relabelling leaves the tets around each vertex as they are: every round shares them.
      const VertexStars stars = check.needed() ? vertexStars(r.mesh) : VertexStars{};
      out.repair = repairLabelsAround(r.mesh, used, p.repairParams, check, contacts, progress, &stars);
      // What it relabelled may have cut a label in two, or made new bad vertices next to the old
      // ones. Small pieces it cut off go to their neighbours (every label was in one piece
      // before). Bad vertices left get a further round around them (kLocalRounds in all), kept
      // only when it leaves fewer bad vertices and no piece (otherwise the labels go back to what
      // they were before it). The whole repair below runs when pieces are left, or when pieces
      // were dissolved and bad vertices are left (then it may join what a local round cannot).
      constexpr int kLocalRounds = 4;
      struct State {
        std::vector<int32_t> materials;
        LabelRepairStats stats;
        LabelRepairCheck check;
        bool dissolved = false;
      } saved;
      bool dissolved = false;
      for (int round = 1; out.repair.relabelledVolume > 0; ++round) {
        progress.beginStage("repair check");
        check = checkLabelRepair(r.mesh, contacts, progress, joins);
        if (check.extraPieces && !check.largeExtraPieces) {
          dissolved = dissolvePieces(r.mesh, check.smallPieces, contacts, out.repair, &stars) > 0 || dissolved;
          check = checkLabelRepair(r.mesh, contacts, progress, joins);
        }
        if (round > 1 && (check.extraPieces || check.badVertices.size() >= saved.check.badVertices.size())) {
          r.mesh.materials.swap(saved.materials); // the further round did not help
          out.repair = std::move(saved.stats);
          check = std::move(saved.check);
          dissolved = saved.dissolved;
          break;
        }
        if (check.extraPieces || check.badVertices.empty() || round == kLocalRounds) break;
        saved = State{r.mesh.materials, out.repair, check, dissolved};
        const LabelRepairStats more = repairLabelsAround(r.mesh, used, p.repairParams, check, contacts, progress, &stars);
        if (more.relabelledVolume == 0) break;
        addLocalRepair(out.repair, more);
        ++out.repair.localRounds;
      }
      whole = check.extraPieces || (dissolved && !check.badVertices.empty());
    }
    if (whole) {
      progress.beginStage("image topology");
      out.image = std::make_shared<const LabelImageTopology>(analyzeLabelImage(argmax, progress));
      const LabelRepairStats local = out.repair;
      out.repair = repairLabels(r.mesh, used, p.repairParams, progress, out.image.get(), joins, &faceNeighbours);
      out.repair.relabelledVolume += local.relabelledVolume;
    }
    if (out.repair.relabelledVolume > 0) refresh();
  }
  const DomainBox box = domainBoxOf(bg.tets(), mats.grid().direction, mats.grid().origin);
  if (p.strip) {
    out.strip = stripExterior(r.mesh, argmax, out.image.get(), StripParams{*p.strip, p.stripCavities}, box, progress,
                              joins, &faceNeighbours);
    // What was culled was stripped before it was meshed.
    out.strip.strippedTets += r.stats.culledTets;
    out.strip.strippedVolume += r.stats.culledVolume;
    r.stats.strippedTets = out.strip.strippedTets;
    std::vector<std::pair<int32_t, int32_t>>().swap(r.exteriorJoins); // tet numbers of the mesh before
    for (auto& m : r.materials)
      if (m.label == *p.strip) {
        m.inputVolume = out.strip.cavityVolume; // what was meant to be meshed
        m.stripped = out.strip.cavityVoxels == 0;
      }
    refresh();
  }
  if (p.correct) {
    std::vector<double> targets;
    for (const auto& m : r.materials) targets.push_back(m.stripped ? 0.0 : m.inputVolume);
    out.correction = correctVolumes(r.mesh, mats.labels(), targets, box, p.correction, progress, &faceNeighbours);
    refresh();
  }
  out.faceNeighbours = std::move(faceNeighbours);
  return out;
}

int64_t finishLabels(TetMesh& mesh, const MaterialSet& materials, CleavePipelineResult& r, Progress& progress) {
  std::vector<int32_t> nb;
  if (r.faceNeighbours.size() == 4 * mesh.numTets()) nb.swap(r.faceNeighbours);
  std::vector<int32_t>().swap(r.faceNeighbours);
  if (!r.image) return 0; // the repair found nothing to do
  LabelRepairParams fp;
  fp.contacts = fp.points = fp.connect = fp.edges = false;
  fp.fragments = true;
  return repairLabels(mesh, materials, fp, progress, r.image.get(), nullptr, &nb).fragments;
}

void writeCleavePipelineReport(const CleavePipelineResult& r, const CleavePipelineParams& p,
                               const std::vector<int32_t>& labels, Report& report) {
  writeCleaveReport(r.cleaved, report);
  if (p.repair) writeLabelRepairReport(r.repair, report);
  if (p.strip) writeStripReport(r.strip, p.stripCavities, report);
  if (p.correct) writeVolumeCorrectionReport(r.correction, report);
  if (p.calibration_rounds > 0) writeVolumeCalibrationReport(r.calibration, labels, report);
}

} // namespace tetflow
