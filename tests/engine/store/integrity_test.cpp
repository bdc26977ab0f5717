// No wrong answer from a damaged file, and one writer per output: every reading command fails
// naming the damaged chunk (exit 1, nothing written); a second run on a locked output is refused
// before any work; outputs that are folders, devices or links are refused; a truncated .partial
// resumes to the bytes of an uninterrupted run.
#include <btf/core/container.h>
#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/core/output_lock.h>
#include <btf/core/rng.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

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

namespace btf {
namespace {

// Rewrites a file's JSON header (a crafted file): magic kept, new length and checksum, the rest
// of the bytes after the old header unchanged.
void rewriteHeader(const std::string& in, const std::string& out,
                   const std::function<void(nlohmann::json&)>& edit) {
  const std::string bytes = test::readFile(in);
  uint64_t len = 0;
  std::memcpy(&len, bytes.data() + 8, 8);
  nlohmann::json j = nlohmann::json::parse(bytes.substr(24, len));
  edit(j);
  const std::string header = j.dump();
  container::Magic magic{};
  std::memcpy(magic.data(), bytes.data(), 8);
  const auto pre = container::preamble(magic, header);
  std::ofstream f(out, std::ios::binary);
  f.write(pre.data(), std::streamsize(pre.size()));
  f << header << bytes.substr(24 + len);
}

TEST(HostileInput, CraftedHeadersAndDeepNestingAreClearErrorsNamingTheField) {
  const auto dir = test::tempDir("hostile_headers");
  const std::string d = dir.string();
  std::string out;
  ASSERT_EQ(
      test::runBtfsim("simulate " + brick() + " -o " + d + "/b.btf --texels 4 --dirs 2x4 -q", &out),
      0)
      << out;
  ASSERT_EQ(test::runBtfsim("compress " + d + "/b.btf -o " + d + "/b.cbtf --codec svd -q", &out), 0)
      << out;
  std::ofstream(dir / "deep.json") << std::string(100000, '[') << std::string(100000, ']');
  auto nest = [](int n) {
    nlohmann::json v = 1;
    for (int k = 0; k < n; ++k) v = nlohmann::json::array({v});
    return v;
  };
  struct Case {
    std::string name;
    std::function<std::string()> make;  // returns the command
    std::string expect;
  } cases[] = {
      {"deep scene", [&] { return "plan " + d + "/deep.json"; },
       "deep.json:1: JSON nested deeper than 64 levels"},
      {"huge texels",
       [&] {
         rewriteHeader(d + "/b.btf", d + "/t.btf", [](auto& j) { j["texels"] = {1000000, 4}; });
         return "info " + d + "/t.btf";
       },
       "t.btf: header field /texels/0: must be an integer in 1..16384"},
      {"wrong type",
       [&] {
         rewriteHeader(d + "/b.btf", d + "/s.btf", [](auto& j) { j["settings"]["spp"] = "x"; });
         return "slice " + d + "/s.btf --texel avg --light 30,0 -o " + d + "/o.png";
       },
       "s.btf: header field /settings/spp: must be an integer in 1..64"},
      {"nested params",
       [&] {
         rewriteHeader(d + "/b.cbtf", d + "/n.cbtf", [&](auto& j) { j["params"] = nest(1000); });
         return "info " + d + "/n.cbtf";
       },
       "n.cbtf (header):1: JSON nested deeper than 64 levels"},
      {"overflowing array",
       [&] {
         rewriteHeader(d + "/b.cbtf", d + "/a.cbtf", [](auto& j) {
           j["arrays"][0]["rows"] = 1099511627776LL;
           j["arrays"][0]["cols"] = 16777216;
         });
         return "info " + d + "/a.cbtf";
       },
       "a.cbtf: header field /arrays/0/rows: must be an integer in 0.."},
      {"array past the end",
       [&] {
         rewriteHeader(d + "/b.cbtf", d + "/e.cbtf", [](auto& j) {
           j["arrays"][0]["offset"] = uint64_t(j["arrays"][0]["offset"]) + 100000;
         });
         return "compare " + d + "/b.btf " + d + "/e.cbtf";
       },
       "e.cbtf: header field /arrays/0/offset: must be an integer in 0.."},
  };
  for (auto& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string cmd = c.make();
    EXPECT_EQ(test::runBtfsim(cmd, &out), 1) << out;
    EXPECT_EQ(out.rfind("btfsim: error: ", 0), 0u) << out;
    EXPECT_NE(out.find(c.expect), std::string::npos) << out;
    EXPECT_EQ(out.find("json.exception"), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

TEST(HostileInput, GeometryOutOfBoundsIsRefusedBeforeWorkNamingThePart) {
  const auto dir = test::tempDir("hostile_geometry");
  std::ofstream(dir / "inf.obj") << "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  auto scene = [&](const std::string& name, const std::string& tile, const std::string& part) {
    std::ofstream(dir / name) << R"({"btfscene": 1, "tile": {"size": )" << tile
                              << R"(}, "materials": {"m": {"type": "lambert", "albedo": 0.5}},
      "parts": [)" << part << "]}";
    return (dir / name).string();
  };
  struct Case {
    std::string scene, expect;
  } cases[] = {
      {scene("inf.json", "[1, 1]", R"({"type": "mesh", "material": "m", "path": "inf.obj"})"),
       "inf.obj:1: malformed OBJ: vertex 1 has a non-finite coordinate"},
      {scene("array.json", "[1, 1]",
             R"({"type": "sphere", "material": "m", "radius": 0.001, "segments": 256,
                 "array": {"count": [1024, 1024]}})"),
       "parts[0] ('sphere0'): 1048576 copies of 65024 triangles"},
      {scene("huge.json", "[1e38, 1e38]", R"({"type": "plane", "material": "m"})"),
       "tile.size[0]: must be <= 1000 (got 1e+38)"},
      {scene("tiny.json", "[1e-30, 1]", R"({"type": "plane", "material": "m"})"),
       "tile.size[0]: must be >= 0.001 (got 1e-30)"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.scene);
    std::string out;
    EXPECT_EQ(test::runBtfsim("plan " + c.scene, &out), 1) << out;
    EXPECT_EQ(out.rfind("btfsim: error: ", 0), 0u) << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;  // one line, no library text
    EXPECT_NE(out.find(c.expect), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace btf

namespace btf {
namespace {

TEST(HostileInput, OutputsThatCannotBeWrittenAreRefusedBeforeWork) {
  const auto dir = test::tempDir("hostile_outputs");
  const std::string d = dir.string();
  std::ofstream(dir / "file.txt") << "not a folder\n";
  fs::create_directories(dir / "folder");
  // A run big enough that doing any work before the refusal would be seen (minutes, not ms).
  const std::string big = "simulate " + brick() + " --texels 512 --dirs 16x32 -o ";
  const std::string raw = d + "/b.btf";
  ASSERT_EQ(
      test::runBtfsim("simulate " + brick() + " -o " + raw + " --texels 2 --dirs 2x4 -q", nullptr),
      0);
  struct Case {
    std::string args, expect;
    int code;
  } cases[] = {
      {big + "''", "--output: must not be empty", 2},
      {big + "/dev/full", "/dev/full: is not a regular file", 1},
      {big + d + "/folder", "folder: is a folder; the output must be a file path", 1},
      {big + d + "/file.txt/x.btf", "x.btf.partial: cannot create (Not a directory)", 1},
      {big + "/sys/x.btf", "/sys/x.btf.partial: cannot create (Permission denied)", 1},
      {"compress " + raw + " -o /dev/null", "/dev/null: is not a regular file", 1},
      {"export " + raw + " --format ubo2003 -o /sys/ubo", "/sys/ubo: cannot create the folder", 1},
      {"export " + raw + " --format ubo2003 -o " + d + "/file.txt", "file.txt: is a file", 1},
      {"slice " + raw + " --view 0,0 --light 0,0 -o " + d + "/x.tga",
       "x.tga: unsupported image type", 1},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    std::string out;
    EXPECT_EQ(test::runBtfsim(c.args, &out), c.code) << out;
    EXPECT_EQ(out.rfind("btfsim: error: ", 0), 0u) << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_NE(out.find(c.expect), std::string::npos) << out;
  }
  EXPECT_FALSE(fs::exists("/sys/ubo"));
  EXPECT_TRUE(test::readFile(dir / "file.txt") == "not a folder\n");  // nothing replaced
}

TEST(HostileInput, GeometryPastTheMemoryBudgetIsRefusedBeforeItIsBuilt) {
  const auto dir = test::tempDir("hostile_budget");
  fs::copy_file(test::sourceDir() + "/resources/meshes/cube_cage.obj", dir / "cage.obj",
                fs::copy_options::overwrite_existing);
  {
    // A 100 × 30 grid of quads as a closed-enough sheet: 6000 triangles.
    std::ofstream f(dir / "sheet.obj");
    for (int j = 0; j <= 30; ++j)
      for (int i = 0; i <= 100; ++i) f << "v " << i / 100.0 << " " << j / 30.0 << " 0\n";
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 100; ++i) {
        const int a = j * 101 + i + 1;
        f << "f " << a << " " << a + 1 << " " << a + 102 << " " << a + 101 << "\n";
      }
  }
  auto scene = [&](const std::string& name, const std::string& part) {
    std::ofstream(dir / name) << R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
      "parts": [)" << part << "]}";
    return (dir / name).string();
  };
  struct Case {
    std::string scene, budget, expect;
  } cases[] = {
      // 6 quads × 4^5 × 2 triangles at level 6 = 49 152 (× 4/3 for the refiner's levels); a
      // 4 MiB budget allows 20 971.
      {scene("subdiv.json",
             R"({"type": "subdiv", "material": "m", "path": "cage.obj", "levels": 6})"),
       "4M",
       "cage.obj: 6 subdivision level(s) of a 6-face cage make 49152 triangles, more than "
       "the 20971 the memory budget allows"},
      {scene("hf.json", R"({"type": "sine", "material": "m", "resolution": [512, 512]})"), "16M",
       "parts[0] ('sine0'): its resolution make 524288 triangles, more than the 83886"},
      {scene("sheet.json", R"({"type": "mesh", "material": "m", "path": "sheet.obj"})"), "1M",
       "sheet.obj: the mesh's first 2622 faces already make 5244 triangles, more than the 5242 "
       "the memory budget allows"},
      {scene("mesh.json", R"({"type": "mesh", "material": "m", "path": "cage.obj",
         "array": {"count": [100, 100]}})"),
       "1M",
       "10000 copies of 12 triangles make the tile 120000 triangles, above the 5242 a 1.0 MiB "
       "memory budget allows"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.scene);
    std::string out;
    EXPECT_EQ(test::runBtfsim("simulate " + c.scene + " -o " + (dir / "o.btf").string() +
                                  " --texels 2 --dirs 2x4 --memory-budget " + c.budget + " -q",
                              &out),
              1)
        << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_NE(out.find(c.expect), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace btf
