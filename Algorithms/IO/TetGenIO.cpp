// Tetrahedral meshes as TetGen's .node / .ele pair (the contracts are MeshIO.h's).
#include "TetGenIO.h"

#include <cmath>
#include <limits>
#include <sstream>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "MeshFileText.h"

namespace tetflow {

using namespace mesh_io;

namespace {

struct TetGenPaths {
  std::string node, ele;
};

// "a/b.node", "a/b.ele" or "a/b" -> {"a/b.node", "a/b.ele"}; an upper-case suffix is kept.
TetGenPaths tetgenPaths(const std::string& path) {
  const std::string ext = fileExtension(path);
  if (ext == ".node" || ext == ".ele") {
    const std::string stem = path.substr(0, path.size() - ext.size());
    const std::string given = path.substr(path.size() - ext.size());
    const bool upper = given != ext;
    TetGenPaths p{stem + (upper ? ".NODE" : ".node"), stem + (upper ? ".ELE" : ".ele")};
    (ext == ".node" ? p.node : p.ele) = path;
    return p;
  }
  return {path + ".node", path + ".ele"};
}

} // namespace

TetMesh readTetGen(const std::string& path) {
  const TetGenPaths p = tetgenPaths(path);
  requireExistingFile(p.node);
  requireExistingFile(p.ele);
  TetMesh m;

  // .node: "<#points> <dim=3> <#attributes> <#markers 0|1>", then "<i> x y z [attr...] [marker]".
  int64_t nodeBase = 0;
  {
    TokenLines in(p.node);
    if (!in.next()) throw InputError(p.node + ": the file is empty (expected a TetGen .node header)");
    const int64_t n = in.integer(0, "number of nodes");
    if (n < 0) in.fail("negative number of nodes");
    if (in.size() > 1 && in.integer(1, "dimension") != 3)
      in.fail("dimension " + std::to_string(in.integer(1, "dimension")) +
              "; only 3D meshes are supported");
    if (n > std::numeric_limits<int32_t>::max()) in.fail("too many nodes for 32-bit indices");
    m.points.reserve(boundedReserve(n, in.bytes(), 8));
    for (int64_t i = 0; i < n; ++i) {
      if (!in.next()) {
        std::ostringstream msg;
        msg << p.node << ": the file ends at line " << in.line() << " after " << i << " of the "
            << n << " nodes announced in the header (truncated file?)";
        throw InputError(msg.str());
      }
      const int64_t idx = in.integer(0, "node index");
      if (i == 0) {
        if (idx != 0 && idx != 1) in.fail("the first node index must be 0 or 1, found " +
                                          std::to_string(idx));
        nodeBase = idx;
      } else if (idx != nodeBase + i) {
        in.fail("node index " + std::to_string(idx) + " out of sequence (expected " +
                std::to_string(nodeBase + i) + ")");
      }
      m.points.push_back({in.real(1, "x coordinate"), in.real(2, "y coordinate"),
                          in.real(3, "z coordinate")});
    }
  }

  // .ele: "<#tets> <nodes per tet 4|10> <#attributes>", then "<i> n1 n2 n3 n4 [attr...]";
  // the first attribute (the region attribute) is the material.
  {
    TokenLines in(p.ele);
    if (!in.next()) throw InputError(p.ele + ": the file is empty (expected a TetGen .ele header)");
    const int64_t nt = in.integer(0, "number of tetrahedra");
    if (nt < 0) in.fail("negative number of tetrahedra");
    const int64_t corners = in.size() > 1 ? in.integer(1, "nodes per tetrahedron") : 4;
    if (corners == 10)
      in.fail("10-node (second-order, TetGen -o2) tetrahedra are not supported; "
              "regenerate the mesh without -o2");
    if (corners != 4)
      in.fail(std::to_string(corners) + " nodes per tetrahedron; only 4 is supported");
    const int64_t nattr = in.size() > 2 ? in.integer(2, "number of attributes") : 0;
    if (nattr < 0) in.fail("negative number of attributes");
    const int64_t np = static_cast<int64_t>(m.points.size());
    m.tets.reserve(boundedReserve(nt, in.bytes(), 10));
    m.materials.reserve(m.tets.capacity());
    int64_t eleBase = 0;
    for (int64_t t = 0; t < nt; ++t) {
      if (!in.next()) {
        std::ostringstream msg;
        msg << p.ele << ": the file ends at line " << in.line() << " after " << t << " of the "
            << nt << " tetrahedra announced in the header (truncated file?)";
        throw InputError(msg.str());
      }
      const int64_t idx = in.integer(0, "tetrahedron index");
      if (t == 0) eleBase = idx;
      else if (idx != eleBase + t)
        in.fail("tetrahedron index " + std::to_string(idx) + " out of sequence (expected " +
                std::to_string(eleBase + t) + ")");
      TetMesh::Tet tet{};
      for (int k = 0; k < 4; ++k) {
        const int64_t v = in.integer(1 + static_cast<size_t>(k), "node number");
        if (v < nodeBase || v >= nodeBase + np) {
          std::ostringstream msg;
          msg << "tetrahedron " << idx << " refers to node " << v << ", but " << p.node
              << " has nodes " << nodeBase << ".." << nodeBase + np - 1;
          in.fail(msg.str());
        }
        tet[k] = static_cast<int32_t>(v - nodeBase);
      }
      int32_t material = 0;
      if (nattr >= 1) {
        const double a = in.real(5, "region attribute");
        if (a != std::floor(a) || a < std::numeric_limits<int32_t>::min() ||
            a > std::numeric_limits<int32_t>::max())
          in.fail("the region attribute of tetrahedron " + std::to_string(idx) +
                  " is not an integer material label");
        material = static_cast<int32_t>(a);
      }
      m.tets.push_back(tet); // TetGen order == TetFlow order (see the file comment)
      m.materials.push_back(material);
    }
  }
  m.validateStructure(p.ele);
  orientPositively(m);
  return m;
}

// Geometry and materials only: fields are not stored. Both files or neither.
void writeTetGen(const std::string& path, const TetMesh& m) {
  const TetGenPaths p = tetgenPaths(path);
  AtomicOutputFile nodeOut(p.node);
  AtomicOutputFile eleOut(p.ele);
  {
    TextSink s(nodeOut.stream());
    s.num(static_cast<int64_t>(m.numPoints())) << "  3  0  0\n";
    for (size_t i = 0; i < m.numPoints(); ++i) {
      s.num(static_cast<int64_t>(i) + 1);
      for (double c : m.points[i]) {
        s << ' ';
        s.real(c);
      }
      s << '\n';
    }
  }
  {
    // Corner order written as stored: TetFlow's positive orientation is TetGen's convention.
    TextSink s(eleOut.stream());
    s.num(static_cast<int64_t>(m.numTets())) << "  4  1\n";
    for (size_t t = 0; t < m.numTets(); ++t) {
      s.num(static_cast<int64_t>(t) + 1);
      for (int32_t v : m.tets[t]) {
        s << ' ';
        s.num(static_cast<int64_t>(v) + 1);
      }
      s << ' ';
      s.num(m.materials[t]) << '\n';
    }
  }
  nodeOut.commit();
  eleOut.commit();
}

} // namespace tetflow
