// Electrode position reader: every format read back with exact coordinates and source lines, the
// delimited-text variants (header, separators, CRLF, x/y/z only), .elc units and layouts, .sfp
// fiducials, unit overrides, every error message (file and line named) and random bytes.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/ElectrodeIO.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

using test::TempDir;
using test::writeBytes;

struct Expected {
  std::string name;
  Vec3 position;
  int line;
};

void expectElectrodes(const std::vector<Electrode>& got, const std::vector<Expected>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    SCOPED_TRACE(want[i].name);
    EXPECT_EQ(got[i].name, want[i].name);
    EXPECT_EQ(got[i].position, want[i].position); // exact: decimal -> double, times 1 or 10
    EXPECT_EQ(got[i].line, want[i].line);
  }
}

std::vector<Electrode> readText(const TempDir& tmp, const std::string& name,
                                const std::string& text, double unitScale = 0.0) {
  const std::string f = tmp.file(name);
  writeBytes(f, text);
  return readElectrodes(f, unitScale);
}

const std::vector<Expected> kThree = {
    {"Fp1", {-29.4, 83.9, -7.0}, 2}, {"Fp2", {29.4, 83.9, -7.0}, 3}, {"Cz", {0.0, 0.0, 100.5}, 4}};

// ---------------------------------------------------------------------------------------------
// Delimited text

TEST(ElectrodeIO, CsvWithHeaderEachSeparator) {
  TempDir tmp;
  expectElectrodes(
      readText(tmp, "a.csv", "name,x,y,z\nFp1,-29.4,83.9,-7\nFp2,29.4,83.9,-7.0\nCz,0,0,100.5\n"),
      kThree);
  expectElectrodes(readText(tmp, "a.tsv",
                            "label\tx\ty\tz\nFp1\t-29.4\t83.9\t-7\nFp2\t29.4\t83.9\t-7\n"
                            "Cz\t0\t0\t100.5\n"),
                   kThree);
  expectElectrodes(
      readText(tmp, "a.txt", "name;x;y;z\nFp1;-29.4;83.9;-7\nFp2;29.4;83.9;-7\nCz;0;0;100.5\n"),
      kThree);
  expectElectrodes(
      readText(tmp, "b.txt", "name x y z\nFp1 -29.4   83.9 -7\n  Fp2\t29.4 83.9 -7\nCz 0 0 100.5"),
      kThree);
  // Blanks around fields, quoted fields, a trailing separator.
  expectElectrodes(readText(tmp, "b.csv",
                            "\"name\", \"x\", \"y\", \"z\"\n\"Fp1\", -29.4, 83.9, -7,\n"
                            " Fp2 , +29.4 , 83.9 , -7.0\nCz,0,0,1005e-1\n"),
                   kThree);
}

TEST(ElectrodeIO, CsvWithoutHeaderCommentsBlankLinesCrlf) {
  TempDir tmp;
  expectElectrodes(
      readText(tmp, "a.csv",
               "# my cap\r\nFp1,-29.4,83.9,-7\r\nFp2,29.4,83.9,-7\r\n\r\n"
               "   # comment\r\nCz,0,0,100.5\r\n"),
      {{"Fp1", {-29.4, 83.9, -7.0}, 2}, {"Fp2", {29.4, 83.9, -7.0}, 3}, {"Cz", {0, 0, 100.5}, 6}});
  expectElectrodes(
      readText(tmp, "b.CSV", "Fp1,-29.4,83.9,-7\nFp2,29.4,83.9,-7\nCz,0,0,100.5"),
      {{"Fp1", {-29.4, 83.9, -7.0}, 1}, {"Fp2", {29.4, 83.9, -7.0}, 2}, {"Cz", {0, 0, 100.5}, 3}});
  // UTF-8 byte order mark (spreadsheet exports), a name with a blank in a tab-separated file.
  expectElectrodes(readText(tmp, "c.tsv", "\xEF\xBB\xBFname\tx\ty\tz\r\nLeft ear\t-80\t0\t-40\r\n"),
                   {{"Left ear", {-80, 0, -40}, 2}});
}

TEST(ElectrodeIO, CsvXyzOnlyNamesElectrodesByPosition) {
  TempDir tmp;
  expectElectrodes(
      readText(tmp, "a.csv", "x,y,z\n1,2,3\n4,5,6\nRef,7,8,9\n-1,-2,-3\n"),
      {{"E1", {1, 2, 3}, 2}, {"E2", {4, 5, 6}, 3}, {"Ref", {7, 8, 9}, 4}, {"E4", {-1, -2, -3}, 5}});
  expectElectrodes(readText(tmp, "b.txt", "1.5 2.5 3.5\n"), {{"E1", {1.5, 2.5, 3.5}, 1}});
}

// ---------------------------------------------------------------------------------------------
// .elc

TEST(ElectrodeIO, ElcMillimetresLabelsOnePerLine) {
  TempDir tmp;
  const auto e =
      readText(tmp, "cap.elc",
               "# ASA electrode file\nReferenceLabel\tavg\nUnitPosition\tmm\nNumberPositions=\t3\n"
               "Positions\n-29.4 83.9 -7\n29.4 83.9 -7\n0 0 100.5\nLabels\nFp1\nFp2\nCz\n");
  expectElectrodes(
      e,
      {{"Fp1", {-29.4, 83.9, -7.0}, 6}, {"Fp2", {29.4, 83.9, -7.0}, 7}, {"Cz", {0, 0, 100.5}, 8}});
}

TEST(ElectrodeIO, ElcCentimetresScaledLabelsOnOneLine) {
  TempDir tmp;
  const auto e = readText(
      tmp, "cap.ELC",
      "NumberPositions=3\r\nUnitPosition cm\r\nPositions\r\n1 2 3\r\n-4 5.5 6\r\n0 0 10\r\n"
      "Labels\r\nFp1 Fp2\tCz\r\n");
  expectElectrodes(e,
                   {{"Fp1", {10, 20, 30}, 4}, {"Fp2", {-40, 55, 60}, 5}, {"Cz", {0, 0, 100}, 6}});
  const auto m = readText(tmp, "m.elc",
                          "NumberPositions= 1\nUnitPosition m\nPositions\n0.5 0 1\nLabels\nCz\n");
  expectElectrodes(m, {{"Cz", {500, 0, 1000}, 4}});
}

TEST(ElectrodeIO, ElcLabelledPositionVariants) {
  TempDir tmp;
  // "Label : x y z" and "Label: x y z" with a Labels section (its labels win) ...
  const auto a = readText(tmp, "a.elc",
                          "NumberPositions= 3\nUnitPosition mm\nPositions\nFp1 : -29.4 83.9 -7\n"
                          "Fp2: 29.4 83.9 -7\nCz :0 0 100.5\nLabels\nFp1 Fp2\nCz\n");
  expectElectrodes(
      a,
      {{"Fp1", {-29.4, 83.9, -7.0}, 4}, {"Fp2", {29.4, 83.9, -7.0}, 5}, {"Cz", {0, 0, 100.5}, 6}});
  // ... and without one: the position lines carry the labels. Trailing sections are ignored.
  const auto b =
      readText(tmp, "b.elc",
               "NumberPositions= 2\nPositions\nFp1 : 1 2 3\nFp2: 4 5 6\nNumberPolygons= 1\n"
               "TypePolygons= 1\nPolygons\n0 1 1\n");
  expectElectrodes(b, {{"Fp1", {1, 2, 3}, 3}, {"Fp2", {4, 5, 6}, 4}});
}

// ---------------------------------------------------------------------------------------------
// .sfp and unit scale

TEST(ElectrodeIO, SfpSkipsFiducials) {
  TempDir tmp;
  const auto e = readText(tmp, "cap.sfp",
                          "FidNz 0 91.0 -42\nFidT9 -85 0 -45\nfidt10 85 0 -45\nFp1 -29.4 83.9 -7\n"
                          "Fp2\t29.4\t83.9\t-7\nCz 0 0 100.5\n");
  expectElectrodes(
      e,
      {{"Fp1", {-29.4, 83.9, -7.0}, 4}, {"Fp2", {29.4, 83.9, -7.0}, 5}, {"Cz", {0, 0, 100.5}, 6}});
}

TEST(ElectrodeIO, UnitScaleMultipliesAndOverridesElcUnit) {
  TempDir tmp;
  expectElectrodes(readText(tmp, "a.sfp", "Cz 0 1.5 10\n", 10.0), {{"Cz", {0, 15, 100}, 1}});
  expectElectrodes(readText(tmp, "a.csv", "Cz,0,1.5,10\n", 1000.0), {{"Cz", {0, 1500, 10000}, 1}});
  const std::string cm = "NumberPositions= 1\nUnitPosition cm\nPositions\n1 2 3\nLabels\nCz\n";
  expectElectrodes(readText(tmp, "cm.elc", cm, 1.0), {{"Cz", {1, 2, 3}, 4}});
  // An override also makes an unknown unit acceptable.
  const std::string in = "NumberPositions= 1\nUnitPosition inch\nPositions\n1 2 3\nLabels\nCz\n";
  expectElectrodes(readText(tmp, "in.elc", in, 25.0), {{"Cz", {25, 50, 75}, 4}});
}

// ---------------------------------------------------------------------------------------------
// Errors

TEST(ElectrodeIO, FileAndArgumentErrors) {
  TempDir tmp;
  const std::string missing = tmp.file("missing.csv");
  EXPECT_THROW_MSG(readElectrodes(missing), InputError, missing, "not found");
  EXPECT_THROW_MSG(readElectrodes(tmp.path().string() + "/"), InputError, "extension");
  const std::string folder = tmp.file("dir.csv");
  std::filesystem::create_directories(folder);
  EXPECT_THROW_MSG(readElectrodes(folder), InputError, "dir.csv", "folder");
  const std::string bad = tmp.file("cap.xyz");
  writeBytes(bad, "Cz 1 2 3\n");
  EXPECT_THROW_MSG(readElectrodes(bad), InputError, "cap.xyz", "'.xyz'", ".csv", ".tsv", ".txt",
                   ".elc", ".sfp");
  EXPECT_THROW_MSG(readElectrodes(tmp.file("cap.csv.gz")), InputError, "cap.csv.gz", "supported");
  const std::string ok = tmp.file("ok.csv");
  writeBytes(ok, "Cz,1,2,3\n");
  for (double s : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()})
    EXPECT_THROW_MSG(readElectrodes(ok, s), InputError, "ok.csv", "unit scale");
  EXPECT_THROW_MSG(readElectrodes(ok, 1e308), InputError, "ok.csv", "line 1", "out of range");
}

TEST(ElectrodeIO, EmptyFiles) {
  TempDir tmp;
  for (const char* name : {"e.csv", "e.tsv", "e.txt", "e.elc", "e.sfp"}) {
    SCOPED_TRACE(name);
    EXPECT_THROW_MSG(readText(tmp, name, ""), InputError, name, "no electrodes");
    EXPECT_THROW_MSG(readText(tmp, name, "# only a comment\r\n\r\n  \n"), InputError, name,
                     "no electrodes");
  }
  EXPECT_THROW_MSG(readText(tmp, "h.csv", "name,x,y,z\n"), InputError, "h.csv", "no electrodes",
                   "header");
  EXPECT_THROW_MSG(readText(tmp, "f.sfp", "FidNz 0 9 1\n"), InputError, "f.sfp", "no electrodes",
                   "fiducials");
  EXPECT_THROW_MSG(readText(tmp, "z.elc", "NumberPositions= 0\nPositions\nLabels\n"), InputError,
                   "z.elc", "no electrodes");
  EXPECT_THROW_MSG(readText(tmp, "n.elc", "UnitPosition mm\nLabels\nCz\n"), InputError, "n.elc",
                   "no 'Positions'");
}

TEST(ElectrodeIO, BadCoordinates) {
  TempDir tmp;
  EXPECT_THROW_MSG(readText(tmp, "a.csv", "Fp1,1,2,3\nFp2,1,abc,3\n"), InputError, "a.csv",
                   "line 2", "y coordinate", "'abc'");
  EXPECT_THROW_MSG(readText(tmp, "b.csv", "# c\nFp1,1,2,nan\n"), InputError, "b.csv", "line 2",
                   "z coordinate", "finite");
  EXPECT_THROW_MSG(readText(tmp, "c.tsv", "Fp1\tinf\t2\t3\n"), InputError, "c.tsv", "line 1",
                   "x coordinate");
  EXPECT_THROW_MSG(readText(tmp, "d.txt", "Fp1 1e999 2 3\n"), InputError, "d.txt", "line 1",
                   "'1e999'");
  EXPECT_THROW_MSG(readText(tmp, "e.csv", "Fp1;1,5;2;3\n"), InputError, "e.csv", "line 1",
                   "decimal point");
  EXPECT_THROW_MSG(readText(tmp, "f.sfp", "Fp1 1 2 3\nFp2 1 2 3x\n"), InputError, "f.sfp", "line 2",
                   "'3x'");
  EXPECT_THROW_MSG(readText(tmp, "g.elc", "NumberPositions= 1\nPositions\n1 - 3\nLabels\nCz\n"),
                   InputError, "g.elc", "line 3", "y coordinate");
  EXPECT_THROW_MSG(readText(tmp, "h.sfp", "FidNz 0 NaN 1\n"), InputError, "h.sfp", "line 1",
                   "y coordinate");
}

TEST(ElectrodeIO, WrongNumberOfFields) {
  TempDir tmp;
  EXPECT_THROW_MSG(readText(tmp, "a.csv", "name,x,y,z\nFp1,1,2,3\nFp2,1,2\n"), InputError, "a.csv",
                   "line 3", "3 field(s)", "'Fp2', not a number", "commas");
  EXPECT_THROW_MSG(readText(tmp, "i.csv", "Fp1,1,2,3\n4,5\n"), InputError, "i.csv", "line 2",
                   "2 field(s)");
  EXPECT_THROW_MSG(readText(tmp, "b.csv", "Fp1,1,2,3,4\n"), InputError, "b.csv", "line 1",
                   "5 field(s)");
  EXPECT_THROW_MSG(readText(tmp, "c.tsv", "Fp1\t1\t2\t3\nFp2 1 2 3\n"), InputError, "c.tsv",
                   "line 2", "tabs");
  EXPECT_THROW_MSG(readText(tmp, "d.txt", "Fp1 1 2 3 4 5 6 7 8 9 10\n"), InputError, "d.txt",
                   "line 1", "more than 8");
  EXPECT_THROW_MSG(readText(tmp, "e.sfp", "Fp1 1 2 3\n\nFp2 1 2\n"), InputError, "e.sfp", "line 3",
                   "'name x y z'", "3 field(s)");
  EXPECT_THROW_MSG(readText(tmp, "f.sfp", "1 2 3\n"), InputError, "f.sfp", "line 1", "3 field(s)");
  EXPECT_THROW_MSG(
      readText(tmp, "g.elc", "NumberPositions= 2\nPositions\n1 2 3\n1 2\nLabels\nA B\n"),
      InputError, "g.elc", "line 4", "'x y z'");
  EXPECT_THROW_MSG(readText(tmp, "h.csv", ",1,2,3\n"), InputError, "h.csv", "line 1",
                   "name is empty");
}

TEST(ElectrodeIO, DuplicateNamesNameBothLines) {
  TempDir tmp;
  EXPECT_THROW_MSG(readText(tmp, "a.csv", "name,x,y,z\nFp1,1,2,3\nCz,0,0,1\nFp1,4,5,6\n"),
                   InputError, "a.csv", "line 4", "first on line 2", "'Fp1'", "unique");
  EXPECT_THROW_MSG(readText(tmp, "b.sfp", "Cz 1 2 3\n# x\nCz 1 2 3\n"), InputError, "b.sfp",
                   "line 3", "first on line 1");
  EXPECT_THROW_MSG(readText(tmp, "c.csv", "1,2,3\nE1,4,5,6\n"), InputError, "c.csv", "line 2",
                   "'E1'");
  // .elc: the lines of the labels.
  EXPECT_THROW_MSG(
      readText(tmp, "d.elc",
               "NumberPositions= 3\nPositions\n1 2 3\n4 5 6\n7 8 9\nLabels\nFp1 Cz\nCz\n"),
      InputError, "d.elc", "line 8", "first on line 7", "'Cz'");
}

TEST(ElectrodeIO, ElcStructureErrors) {
  TempDir tmp;
  const std::string labels = "Labels\nA\nB\n";
  EXPECT_THROW_MSG(readText(tmp, "a.elc", "NumberPositions= 3\nPositions\n1 2 3\n4 5 6\n" + labels),
                   InputError, "a.elc", "line 1", "NumberPositions= 3", "2 position(s)");
  EXPECT_THROW_MSG(readText(tmp, "b.elc", "NumberPositions= 1\nPositions\n1 2 3\n4 5 6\n" + labels),
                   InputError, "b.elc", "line 1", "2 position(s)");
  EXPECT_THROW_MSG(
      readText(tmp, "c.elc", "NumberPositions= 2\nPositions\n1 2 3\n4 5 6\nLabels\nA B C\n"),
      InputError, "c.elc", "line 5", "3 label(s)", "2 positions");
  EXPECT_THROW_MSG(
      readText(tmp, "d.elc", "NumberPositions= 2\nPositions\n1 2 3\n4 5 6\nLabels\nA\n"),
      InputError, "d.elc", "line 5", "1 label(s)");
  EXPECT_THROW_MSG(
      readText(tmp, "e.elc",
               "NumberPositions= 2\nUnitPosition inch\nPositions\n1 2 3\n4 5 6\n" + labels),
      InputError, "e.elc", "line 2", "'inch'", "mm, cm or m");
  EXPECT_THROW_MSG(
      readText(tmp, "f.elc", "NumberPositions= two\nPositions\n1 2 3\n4 5 6\n" + labels),
      InputError, "f.elc", "line 1", "'two'");
  EXPECT_THROW_MSG(readText(tmp, "g.elc", "NumberPositions= 2\nPositions\n1 2 3\n4 5 6\n"),
                   InputError, "g.elc", "line 3", "no label");
  EXPECT_THROW_MSG(
      readText(tmp, "h.elc", "NumberPositions= 1\nPositions\n1 2 3\nPositions\n1 2 3\n"),
      InputError, "h.elc", "line 4", "again", "line 2");
}

TEST(ElectrodeIO, ControlCharactersInNames) {
  TempDir tmp;
  EXPECT_THROW_MSG(readText(tmp, "a.sfp", std::string("C\x01z 1 2 3\n")), InputError, "a.sfp",
                   "line 1", "control characters");
  EXPECT_THROW_MSG(readText(tmp, "b.csv", std::string("Cz\0,1,2,3\n", 10)), InputError, "b.csv",
                   "line 1", "control characters");
}

// ---------------------------------------------------------------------------------------------
// Robustness

TEST(ElectrodeIO, RandomBytesEitherParseOrInputError) {
  TempDir tmp;
  std::mt19937 rng(20240611);
  // Even inputs: raw random bytes. Odd inputs: a valid file of some format with a few random
  // edits (pieces of the formats inserted, ranges deleted), which reaches the deeper paths.
  const std::vector<std::string> seeds = {
      "name,x,y,z\nFp1,-29.4,83.9,-7\nFp2,29.4,83.9,-7\n1,2,3\n",
      "NumberPositions= 3\nUnitPosition cm\nPositions\n1 2 3\nB: 4 5 6\n7 8 9\nLabels\nA B\nC\n",
      "FidNz 0 9 -4\nFp1 -29.4 83.9 -7\nCz\t0\t0\t100\n"};
  const std::vector<std::string> pieces = {"\n",
                                           "\r\n",
                                           " ",
                                           "\t",
                                           ",",
                                           ";",
                                           ":",
                                           "=",
                                           "#",
                                           "\"",
                                           "1",
                                           "-2.5",
                                           "1e308",
                                           "nan",
                                           "Fp1",
                                           "FidNz",
                                           "E1",
                                           "NumberPositions",
                                           "UnitPosition",
                                           "Positions",
                                           "Labels",
                                           "m",
                                           "\xEF\xBB\xBF",
                                           std::string(1, '\0')};
  int parsed = 0, refused = 0;
  for (int i = 0; i < 200; ++i) {
    std::string bytes;
    if (i % 2 == 0) {
      bytes.resize(rng() % 400);
      for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
    } else {
      bytes = seeds[(i / 2) % seeds.size()];
      for (int edits = 1 + rng() % 3; edits > 0; --edits) {
        const size_t at = rng() % (bytes.size() + 1);
        if (rng() % 2)
          bytes.insert(at, pieces[rng() % pieces.size()]);
        else
          bytes.erase(at, rng() % 4);
      }
    }
    for (const char* name : {"f.csv", "f.tsv", "f.txt", "f.elc", "f.sfp"}) {
      try {
        const auto e = readText(tmp, name, bytes, (i % 7 == 0) ? 2.5 : 0.0);
        ASSERT_FALSE(e.empty());
        for (const Electrode& el : e) {
          EXPECT_FALSE(el.name.empty());
          EXPECT_GE(el.line, 1);
          for (double v : el.position) EXPECT_TRUE(std::isfinite(v));
        }
        ++parsed;
      } catch (const InputError& err) {
        EXPECT_NE(std::string(err.what()).find(name), std::string::npos) << err.what();
        ++refused;
      } catch (const std::exception& err) {
        ADD_FAILURE() << name << " input " << i << ": unexpected exception " << err.what();
      }
    }
  }
  EXPECT_GT(parsed, 0);
  EXPECT_GT(refused, 0);
  EXPECT_EQ(parsed + refused, 1000);
}

TEST(ElectrodeIO, HugeLinesAreRefusedQuickly) {
  TempDir tmp;
  const auto start = std::chrono::steady_clock::now();
  const std::string blanks(8 << 20, ' ');
  std::string words;
  for (int i = 0; i < (2 << 20); ++i) words += "ab ";
  for (const char* name : {"h.csv", "h.elc", "h.sfp"}) {
    EXPECT_THROW(readText(tmp, name, "Cz 1 2 3" + blanks + "x\n"), InputError) << name;
    EXPECT_THROW(readText(tmp, name, std::string(8 << 20, '7') + "\n"), InputError) << name;
    EXPECT_THROW(readText(tmp, name, words), InputError) << name;
  }
  EXPECT_THROW(readText(tmp, "l.elc", "NumberPositions= 1\nPositions\n1 2 3\nLabels\n" + words),
               InputError);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 20.0);
}

} // namespace
} // namespace tetflow
