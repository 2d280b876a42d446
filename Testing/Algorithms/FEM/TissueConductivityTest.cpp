// Tests for Algorithms/FEM/TissueConductivity: the literature table by name and alias, tissue
// names in the conductivities list, and the order in which a label's conductivity is chosen.
#include "Algorithms/FEM/TissueConductivity.h"

#include <gtest/gtest.h>

#include "Algorithms/Core/Errors.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

TEST(TissueConductivity, LiteratureValuesByNameAndAlias) {
  struct Case {
    const char* name;
    double sigma;
    const char* matched;
  };
  for (const Case& c : {Case{"white matter", 0.126, "white matter"}, Case{"WM", 0.126, "white matter"},
                        Case{"Left-Cerebral-White-Matter", 0.126, "white matter"}, Case{"Gray-Matter", 0.275, "grey matter"},
                        Case{"rh_cortex", 0.275, "grey matter"}, Case{"CSF", 1.654, "CSF"},
                        Case{"Right-Lateral-Ventricle", 1.654, "CSF"}, Case{"skull", 0.010, "bone"},
                        Case{"Compact_bone", 0.008, "compact bone"}, Case{"Spongy_bone", 0.025, "spongy bone"},
                        Case{"Scalp", 0.465, "scalp"}, Case{"skin", 0.465, "scalp"}, Case{"Eye_balls", 0.5, "eyes"},
                        Case{"Blood", 0.6, "blood"}, Case{"Muscle", 0.16, "muscle"}, Case{"air", 2.5e-14, "air"}}) {
    std::string matched;
    const auto s = literatureConductivity(c.name, &matched);
    ASSERT_TRUE(s.has_value()) << c.name;
    EXPECT_EQ(*s, c.sigma) << c.name;
    EXPECT_EQ(matched, c.matched) << c.name;
  }
  for (const char* unknown : {"brain", "Left-Hippocampus", "", "leftover", "Unknown"})
    EXPECT_FALSE(literatureConductivity(unknown).has_value()) << unknown;
}

TEST(TissueConductivity, NamesInTheListBecomeLabels) {
  const std::map<int32_t, std::string> names{{1, "scalp"}, {2, "skull"}, {3, "CSF"}, {7, "csf"}};
  EXPECT_EQ(conductivityItemsByLabel({"CSF: 1.79", "2:0.01", " Scalp :0.43", "5:1 1 2 0 0 0"}, names),
            (std::vector<std::string>{"3: 1.79", "7: 1.79", "2:0.01", "1:0.43", "5:1 1 2 0 0 0"}));
  EXPECT_THROW_MSG(conductivityItemsByLabel({"brain:0.33"}, names), InputError, "'brain:0.33'",
                   "no tissue called 'brain'", "scalp (1), skull (2), CSF (3)");
  EXPECT_THROW_MSG(conductivityItemsByLabel({"brain:0.33"}, {}), InputError, "give labels instead");
  // A mesh's own names match whole (case, spaces, '-' and '_' aside): a hemisphere stays itself.
  const std::map<int32_t, std::string> fs{{2, "Left-Cerebral-White-Matter"}, {41, "Right-Cerebral-White-Matter"}};
  EXPECT_EQ(conductivityItemsByLabel({"left cerebral_white matter:0.2"}, fs), (std::vector<std::string>{"2:0.2"}));
}

TEST(TissueConductivity, ParameterThenLabelTableThenLiteratureThenDefault) {
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}, {0, 1, 2, 3}, {0, 1, 2, 3}, {0, 1, 2, 3}, {0, 1, 2, 3}};
  m.materials = {1, 2, 3, 4, 5};
  m.materialNames = {{1, "scalp"}, {2, "skull"}, {3, "CSF"}, {4, "brain"}};
  m.materialConductivities = {{2, 0.0042}};
  ConductivityTable t = parseConductivities({"3:1.79"}, 0.5);
  auto sources = completeConductivities(t, m, true);
  EXPECT_EQ(sources, (std::map<int32_t, std::string>{
                         {1, "literature"}, {2, "label table"}, {3, "parameter"}, {4, "default"}, {5, "default"}}));
  EXPECT_EQ(t.tensor(1)[0], 0.465);
  EXPECT_EQ(t.tensor(2)[0], 0.0042);
  EXPECT_EQ(t.tensor(3)[0], 1.79);
  EXPECT_EQ(t.tensor(4)[0], 0.5);
  // By name off: the literature is not asked.
  t = parseConductivities({}, 0.5);
  sources = completeConductivities(t, m, false);
  EXPECT_EQ(sources.at(1), "default");
  EXPECT_EQ(t.tensor(1)[0], 0.5);
  EXPECT_EQ(sources.at(2), "label table");
}

} // namespace
} // namespace tetflow
