// No wrong answer from a damaged file, and one writer per output: every reading command fails
// naming the damaged chunk (exit 1, nothing written); a second run on a locked output is refused
// before any work; outputs that are folders, devices or links are refused; a truncated .partial
// resumes to the bytes of an uninterrupted run.
#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/core/output_lock.h>
#include <btf/core/rng.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

namespace fs = std::filesystem;

std::string brick() {
  return test::sourceDir() + "/resources/scenes/brick.json";
}

TEST(Checksum, StreamingEqualsOneShotForAnySplit) {
  std::vector<unsigned char> data(1000);
  for (size_t i = 0; i < data.size(); ++i) data[i] = (unsigned char)(mix64(i) & 0xff);
  for (size_t n : {0, 1, 31, 32, 33, 64, 999, 1000}) {
    const uint64_t one = checksum64(data.data(), n, 7);
    for (size_t cut : {size_t(0), size_t(1), size_t(5), size_t(32), n / 2, n}) {
      if (cut > n) continue;
      Checksum64 c(7);
      c.update(data.data(), cut);
      c.update(data.data() + cut, 3 > n - cut ? n - cut : 3);
      c.update(data.data() + cut + (3 > n - cut ? n - cut : 3),
               n - cut - (3 > n - cut ? n - cut : 3));
      EXPECT_EQ(c.finish(), one) << n << " split at " << cut;
    }
  }
}

TEST(Integrity, EveryReaderRefusesADamagedChunkNamingIt) {
  const auto dir = test::tempDir("integrity_read");
  const std::string d = dir.string(), btf = d + "/b.btf";
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + brick() + " -o " + btf +
                                " --texels 8 --dirs 4x8 --chunk-texels 16 -q",
                            &out),
            0)
      << out;
  // Flip one byte in the middle of chunk 2's data (chunks of 16 texels).
  {
    BtfReader r(btf);
    const uint64_t off = r.layout().chunkOffset(r.info(), 2) + 1000;
    std::fstream f(btf, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(off));
    char b = 0;
    f.read(&b, 1);
    b = char(b ^ 0x5a);
    f.seekp(std::streamoff(off));
    f.write(&b, 1);
  }
  fs::copy_file(btf, d + "/copy.btf");
  const std::string cases[] = {
      "info " + btf,
      "compare " + btf + " " + d + "/copy.btf",
      "compress " + btf + " -o " + d + "/o1.cbtf --codec svd",
      "export " + btf + " --format ubo2014 -o " + d + "/o2.dfmf --components 2",
      "export " + btf + " --format merl -o " + d + "/o3.merl --phi-samples 2",
      "export " + btf + " --format ubo2003 -o " + d + "/o4",
      "slice " + btf + " --view 0,0 --light 30,0 -o " + d + "/o5.png",
      "slice " + btf + " --texel avg --light 30,0 -o " + d + "/o6.exr",
      "slice " + btf + " --texel 3,2 --light 30,0 -o " + d + "/o7.exr",  // texel 19: chunk 1
  };
  int k = 0;
  for (const auto& c : cases) {
    SCOPED_TRACE(c);
    const int rc = test::runBtfsim(c + " -q", &out);
    if (c.find("--texel 3,2") != std::string::npos) {
      EXPECT_EQ(rc, 0) << out;  // a reader that touches only sound chunks is not refused
      continue;
    }
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("chunk 2 checksum mismatch"), std::string::npos) << out;
    ++k;
  }
  EXPECT_EQ(k, 8);
  for (const char* o : {"o1.cbtf", "o2.dfmf", "o3.merl", "o4", "o5.png", "o6.exr"}) {
    EXPECT_FALSE(fs::exists(dir / o)) << o;
    EXPECT_FALSE(fs::exists(dir / (std::string(o) + ".partial"))) << o;
  }
}

TEST(Integrity, OneWriterPerOutputAndOutputsThatCannotBeReplaced) {
  const auto dir = test::tempDir("integrity_write");
  const std::string d = dir.string();
  std::string out;
  {
    OutputLock held(d + "/x.btf");  // another run writing x.btf
    EXPECT_EQ(
        test::runBtfsim("simulate " + brick() + " -o " + d + "/x.btf --texels 4 --dirs 2x4", &out),
        1);
    EXPECT_NE(out.find("x.btf: another run is writing it"), std::string::npos) << out;
    EXPECT_EQ(out.find("estimate"), std::string::npos) << "work started: " << out;
    EXPECT_THROW(OutputLock again(d + "/x.btf"), Error);
  }
  // Released: the run goes through, and leaves no .partial.
  EXPECT_EQ(
      test::runBtfsim("simulate " + brick() + " -o " + d + "/x.btf --texels 4 --dirs 2x4 -q", &out),
      0)
      << out;
  EXPECT_TRUE(fs::exists(dir / "x.btf"));
  EXPECT_FALSE(fs::exists(dir / "x.btf.partial"));
  fs::create_directories(dir / "folder");
  fs::create_symlink(dir / "x.btf", dir / "link.btf");
  struct Case {
    std::string output, expect;
  } cases[] = {{d + "/folder", "folder: is a folder; the output must be a file path"},
               {d + "/link.btf", "link.btf: is a symbolic link"},
               {"/dev/null", "/dev/null: is not a regular file"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.output);
    EXPECT_EQ(
        test::runBtfsim("simulate " + brick() + " -o " + c.output + " --texels 4 --dirs 2x4", &out),
        1);
    EXPECT_NE(out.find(c.expect), std::string::npos) << out;
    EXPECT_EQ(out.find("estimate"), std::string::npos) << "work started: " << out;
  }
  EXPECT_TRUE(fs::is_symlink(dir / "link.btf"));
}

TEST(Integrity, ATruncatedPartialResumesToTheUninterruptedBytes) {
  const auto dir = test::tempDir("integrity_resume");
  const std::string d = dir.string();
  const std::string args = " --texels 8 --dirs 4x8 --chunk-texels 8 -q";
  std::string out;
  ASSERT_EQ(test::runBtfsim("simulate " + brick() + " -o " + d + "/full.btf" + args, &out), 0)
      << out;
  const std::string full = test::readFile(dir / "full.btf");
  for (double keep : {0.7, 0.3, 0.001}) {
    SCOPED_TRACE(keep);
    {
      std::ofstream f(dir / "r.btf.partial", std::ios::binary);
      f.write(full.data(), std::streamsize(double(full.size()) * keep));
    }
    fs::remove(dir / "r.btf");
    ASSERT_EQ(test::runBtfsim("simulate " + brick() + " -o " + d + "/r.btf --resume" + args, &out),
              0)
        << out;
    EXPECT_NE(out.find(keep > 0.01 ? "was truncated" : "was unreadable"), std::string::npos) << out;
    EXPECT_TRUE(test::readFile(dir / "r.btf") == full);
  }
}

}  // namespace
}  // namespace btf
