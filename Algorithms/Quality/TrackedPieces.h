// Same-label pieces of a mesh whose labels change a little between one look and the next (the
// label repair's rounds): the pieces sameLabelPieces gives, at about the cost of the tets that
// changed instead of a union-find over every tet.
#pragma once

#include <cstdint>
#include <vector>

#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Quality/LabelTopology.h"

namespace tetflow {

class TrackedPieces {
public:
  // nb: the mesh's face neighbours (tetFaceNeighbours); joins as for sameLabelPieces. The mesh's
  // tets and faces must stay as they are; only its labels change between calls. All three are
  // read at every call.
  TrackedPieces(const TetMesh& mesh, const std::vector<int32_t>& nb, const TetJoins* joins = nullptr);

  // The pieces of the mesh's labels now: the sets of sameLabelPieces(mesh, nb, joins), every tet
  // pointing straight at its set's root (its smallest tet). The first call joins every tet. A later
  // one starts from the call before: what is left of a piece some tets left is searched from the
  // tets next to them (small parts that came off are found whole), the tets that took a label join
  // the pieces they touch, and the roots that changed are renumbered. When the searches run past
  // their bound, or cannot tell two large parts apart, or more than a 32nd of the tets changed,
  // every tet is joined again.
  DisjointSets now();

  // How many calls joined every tet (the first included), and how many parts that came off a piece
  // the other calls found: for tests and reports.
  int64_t wholeRounds() const { return whole_; }
  int64_t partsCutOff() const { return cutOff_; }

private:
  bool update(); // false: join every tet instead
  template <class F>
  void forNeighbours(int32_t t, F&& f) const;

  const TetMesh& mesh_;
  const std::vector<int32_t>& nb_;
  const TetJoins* joins_;
  std::vector<int64_t> joinStart_; // joins by tet (CSR), built at the first call
  std::vector<int32_t> joinList_;
  std::vector<int32_t> root_;   // per tet, its piece's root, for the labels in labels_
  std::vector<int32_t> labels_; // the labels at the last call
  int64_t whole_ = 0;
  int64_t cutOff_ = 0;
};

} // namespace tetflow
