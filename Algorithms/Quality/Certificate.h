#pragma once
// The mesh certificate: does a labelled tetrahedral mesh keep what its segmentation has?
//
// certifyMesh() compares a TetMesh (per-tet material label = label value) with the LabelVolume it
// was made from, label by label. Every figure is defined here; docs/certificate.md repeats the rules.
//
// Volumes. Voxel volume of label L = voxel count x voxel volume; mesh volume = sum of the volumes
// of the tets labelled L. Absolute error = mesh - voxels [mm^3], relative = absolute / voxels.
//
// Components.
//  - Image: the 26-connected components of each label's voxels. A component is *robust* when it
//    contains a core voxel: one whose six face neighbours all carry its label (neighbours outside
//    the volume count as the same label: the box does not erode). Its *cores* are the
//    26-connected components of its core voxels.
//  - Mesh: the components of each label's tets joined by shared faces.
//  - Matching by overlap: every tet votes, with its volume, for the image component of its label
//    at the voxel containing its centroid; when that voxel has another label, for the nearest
//    voxel of its label among the 26 neighbours (centre distance in mm); otherwise for nothing.
//    Mesh component M overlaps image component C when one of M's tets votes for C.
//  - The rule (per label): the mesh has at least one component for every robust image
//    component, at most the image's 26-connected components, and nothing else:
//      lost        a robust image component that no mesh component overlaps;
//      lost_small  a component without a core that no mesh component overlaps (listed, allowed);
//      split       an image component overlapped by more mesh components than max(1, its cores)
//                  (a thin bridge between two cores may break; nothing else may);
//      merged      a mesh component that overlaps two or more robust image components;
//      spurious    a mesh component that overlaps no image component of its label.
//    Each listed issue carries the voxel count (image side) or volume (mesh side) and where it is
//    in mm: centroid and bounding box.
//
// Small components (the volume check). A lattice cannot keep a component smaller than its
// elements to a percentage of its volume: a one-voxel cavity under 4 mm elements is a tet or
// nothing. Each image component C gets a local element size h_C: the mean, over its voxel centres
// held by the mesh, of the longest edge of the tet holding the centre (whatever that tet's label;
// a component no tet holds has none). C is *small* when its voxel volume is below h_C^3. A label's
// volume allowance is the sum of h_C^3 over its small components; with thresholds, a label passes
// the volume check when |absolute error| <= max(max_volume_error x voxel volume, allowance x
// small_component_allowance). A label made only of small components is so judged by presence
// and topology (the component rule: a small component with a core voxel must still be kept).
//
// Contacts. Image: two labels touch when some voxel pair sharing a face carries them; the contact
// area is the number of such voxel faces x the face area. Mesh: the area of the faces between a
// tet of each label. A *spurious* contact is a pair that touches in the mesh but not in the image
// (its area, centroid and box are listed); a *missing* one touches in the image but not in the
// mesh.
//
// Interfaces. The surface of label L is the set of faces between an L tet and a tet of another
// label or the outside. A non-manifold interface edge lies in more than two faces of one label's
// surface (the label touches itself along the edge). A non-manifold interface vertex has, in its
// star, the tets of some label, or the tets of all other labels, in more than one group joined
// through faces at the vertex (the label is pinched at the vertex).
//
// Stripped exteriors: when the components of a label that reach the volume's boundary (a voxel on
// the box) get tets of the label voting for at most 1 % of their voxel volume, while the label has
// tets elsewhere and at most half of those components' voxel centres lie in the mesh (a box
// component lost under other labels' tets was not stripped), that label's exterior was stripped (CleaveMesh's strip_exterior keeps cavities):
// those components are left out of the volume (the label's voxels are its other components), the
// component rule, the contacts (voxel pairs with a stripped voxel do not count) and the voxel
// agreement, and are reported as stripped (voxels, mm^3). What was kept is compared with exactly
// the voxels that were meant to be kept.
// Excluded labels: a label of the image with no tets whose voxel centres lie outside the mesh
// (at most 1 % inside), e.g. the background removed entirely (strip_cavities). It is listed
// and not compared; the faces of the mesh boundary are its contacts and are not compared either.
// Voxel agreement: the fraction of voxel centres, over the non-excluded labels, that lie in a tet
// of their own label (centres in no tet count as disagreeing).
//
// Per-tet flags (cell field "certificate_flags", bits): 1 spurious component, 2 extra piece of a
// split component (every piece but the largest), 4 merging component, 8 the tet contains a voxel
// centre of a lost component or its centroid lies in one of its voxels, 16 the tet has a face on a spurious contact, 32 the tet has a
// non-manifold interface edge or vertex. 0 everywhere on a mesh that passes.
//
// Runs on all OpenMP threads where it matters (rasterisation, votes, stars); results do not
// depend on the thread count. Memory: about 40 bytes per tet and 12 per voxel.
// Stages reported to the Progress sink: "image", "mesh", "match", "interfaces".
// Errors (InputError): a mesh failing validateStructure or without tets, an empty volume.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"
#include "LabelTopology.h"

namespace tetflow {

enum class ComponentIssueKind { Lost, LostSmall, Split, Merged, Spurious };
const char* componentIssueName(ComponentIssueKind k); // "lost", "lost_small", ...

struct ComponentIssue {
  ComponentIssueKind kind = ComponentIssueKind::Lost;
  int32_t label = 0;
  int64_t voxels = 0;   // image component size (lost, lost_small, split); 0 for mesh-side issues
  int cores = 0;        // cores of the image component (lost, split)
  int pieces = 0;       // split: mesh components overlapping it; merged: image components joined
  double meshVolume = 0.0; // mesh-side issues (merged, spurious): the component's volume [mm^3]
  Place where;
};

struct ContactIssue {
  int32_t a = 0, b = 0;   // a < b
  double meshArea = 0.0;  // [mm^2]
  double imageArea = 0.0; // [mm^2]
  Place where;            // of the mesh faces (spurious) or the voxel faces (missing)
};

struct LabelCertificate {
  int32_t label = 0;
  bool excluded = false;
  int64_t voxels = 0;
  double voxelVolume = 0.0; // [mm^3]
  int64_t tets = 0;
  double meshVolume = 0.0;  // [mm^3]
  double absError = 0.0;    // mesh - voxels [mm^3]
  double relError = 0.0;    // absError / voxelVolume
  int imageComponents = 0;  // 26-connected
  int robustComponents = 0;
  int meshComponents = 0;   // face-connected
  int lost = 0, lostSmall = 0, split = 0, merged = 0, spurious = 0;
  double agreement = 0.0;   // fraction of this label's voxel centres inside its own tets
  int64_t nonmanifoldEdges = 0, nonmanifoldVertices = 0;
  // Components smaller than an element (below): how many, and the sum of their h^3 [mm^3].
  int smallComponents = 0;
  double volumeAllowance = 0.0;
  int64_t strippedVoxels = 0;  // voxels of a stripped exterior (not in `voxels`)
  double strippedVolume = 0.0; // [mm^3]
};

struct CertificateResult {
  std::vector<LabelCertificate> labels; // every label of the image or the mesh, ascending
  std::vector<int32_t> excludedLabels;
  std::vector<int32_t> strippedLabels; // labels whose exterior was stripped (their cavities compared)
  std::vector<ComponentIssue> componentIssues; // sorted: kind, then size descending
  std::vector<ContactIssue> spuriousContacts;  // area descending
  std::vector<ContactIssue> missingContacts;   // image area descending
  int64_t nonmanifoldEdges = 0, nonmanifoldVertices = 0;
  std::vector<Vec3> nonmanifoldPlaces; // up to 20 edge midpoints / vertices [mm]
  double agreement = 0.0;
  double worstRelError = 0.0; // largest |relError| over the compared labels
  int32_t worstLabel = 0;
  int lost = 0, lostSmall = 0, split = 0, merged = 0, spurious = 0;
  double spuriousContactArea = 0.0; // [mm^2]
  std::vector<int32_t> flags;       // per tet, bits as above
  // Tissue names of the labels (the mesh's, else the label volume's); messages say "label 3 (CSF)".
  std::map<int32_t, std::string> names;
  // "label 3 (CSF)", or "label 3" without a name; "labels 3 (CSF) and 4 (brain)"; "3 (CSF)".
  std::string labelText(int32_t label) const;
  std::string labelPairText(int32_t a, int32_t b) const;
  std::string numberAndName(int32_t label) const;
};

CertificateResult certifyMesh(const TetMesh& mesh, const LabelVolume& labels, Progress& progress);

// Pass/fail thresholds (EvaluateQuality's parameters, `tetflow certify`'s options).
struct CertificateThresholds {
  double maxVolumeError = 0.0;        // largest allowed |relative volume error|; 0 = not checked
  bool requireComponents = false;     // no lost, split, merged or spurious component
  bool forbidSpuriousContacts = false;
  // A label whose |absolute error| is at most this x its volumeAllowance passes the volume check
  // whatever its relative error (0 = every label by maxVolumeError alone).
  double smallComponentAllowance = 1.0;
};

// Empty when the result meets the thresholds; otherwise one message per failed threshold naming
// its worst offender (label, size, place) and what to try.
std::vector<std::string> certificateFailures(const CertificateResult& r, const CertificateThresholds& t);

// "(x, y, z) mm, box [x0..x1, y0..y1, z0..z1]" with one decimal.
std::string describePlace(const Place& p);

// Fills `report` with keys prefixed "cert_" (docs/certificate.md lists them): the rule,
// totals, per label figures (cert_label_L_*), every issue as one text line (cert_issue_N,
// cert_spurious_contact_N, cert_missing_contact_N) up to `maxListed` of each.
void writeCertificateReport(const CertificateResult& r, Report& report, size_t maxListed = 50);

} // namespace tetflow
