#include "msspr_core/progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::ReadText;
using testing_util::TempDir;

TEST(ProgressTest, CsvHeaderOnceAndAppends) {
  TempDir dir;
  const std::string path = dir.File("m.csv");
  {
    CsvWriter w(path, {"step", "loss"});
    w.Write({1, 0.5});
  }
  {
    CsvWriter w(path, {"step", "loss"});  // a resumed run appends
    w.Write({2, 0.25});
    EXPECT_THROW(w.Write({3}), std::runtime_error);
  }
  EXPECT_EQ(ReadText(path), "step,loss\n1,0.5\n2,0.25\n");
  EXPECT_THROW(CsvWriter(dir.File("no/such/dir.csv"), {"a"}), std::runtime_error);
}

// A run resumed by a version that logs other columns: the old rows move
// under the new header by column name, nothing is appended under the old one.
TEST(ProgressTest, CsvWithOtherColumnsIsRewrittenUnderTheNewHeader) {
  TempDir dir;
  const std::string path = dir.File("m.csv");
  {
    CsvWriter w(path, {"step", "loss", "gone"});
    w.Write({1, 0.5, 7});
    w.Write({2, 0.25, 8});
  }
  {
    CsvWriter w(path, {"step", "loss", "subgoal"});
    w.Write({3, 0.125, 4});
  }
  EXPECT_EQ(ReadText(path), "step,loss,subgoal\n1,0.5,nan\n2,0.25,nan\n3,0.125,4\n");
}

TEST(ProgressTest, PlainLinesWhenNotATerminal) {
  TempDir dir;
  const std::string path = dir.File("log.txt");
  FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  ProgressBar bar(0, 100, f);
  bar.Update(50, {{"critic", 1.5}});
  bar.Message("eval step 50: success=0.5");
  bar.Update(100, {{"critic", 1.25}});
  bar.Finish();
  std::fclose(f);
  const std::string text = ReadText(path);
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_NE(text.find("50/100"), std::string::npos);
  EXPECT_NE(text.find("it/s eta"), std::string::npos);
  EXPECT_NE(text.find("critic=1.5"), std::string::npos);
  EXPECT_NE(text.find("eval step 50: success=0.5\n"), std::string::npos);
  EXPECT_NE(text.find("100/100"), std::string::npos);
}

TEST(ProgressTest, CsvWriteErrorsNameTheFile) {
  // /dev/full accepts the open and fails every write (ENOSPC).
  try {
    CsvWriter w("/dev/full", {"step", "x"});
    w.Write({1, 2});
    FAIL() << "no error writing to /dev/full";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
  }
}

TEST(ProgressTest, TruncateCsvRowsDropsRowsAfterAStepAndAPartialLastRow) {
  TempDir dir;
  const std::string path = dir.File("m.csv");
  testing_util::WriteText(path, "step,x\n10,1\n20,2\n30,3\n40,4\n5");  // "5": cut short by a kill
  EXPECT_EQ(TruncateCsvRows(path, 20), 3);
  EXPECT_EQ(ReadText(path), "step,x\n10,1\n20,2\n");
  EXPECT_EQ(TruncateCsvRows(path, 20), 0);
  EXPECT_EQ(TruncateCsvRows(dir.File("missing.csv"), 0), 0);
  {
    CsvWriter w(path, {"step", "x"});  // appends after the kept rows, no second header
    w.Write({30, 9});
  }
  EXPECT_EQ(ReadText(path), "step,x\n10,1\n20,2\n30,9\n");
}

}  // namespace
}  // namespace core
}  // namespace msspr
