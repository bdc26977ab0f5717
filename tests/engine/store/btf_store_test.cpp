// The raw store: round trip, corruption detection, atomic writes, and resume that reproduces an
// uninterrupted run byte for byte.
#include <btf/core/error.h>
#include <btf/store/btf_store.h>
#include <gtest/gtest.h>

#include <fstream>

#include "test_util.h"

namespace btf {
namespace {

BtfInfo smallInfo() {
  BtfInfo i;
  i.nu = 5;
  i.nv = 3;
  i.directionSet = "1x2";
  i.dirsDeg = {{45, 90}, {45, 270}};
  i.chunkTexels = 4;
  i.sceneName = "synthetic";
  i.sceneHash = "0";
  i.sceneJson = "{}";
  i.plan = "{}";
  return i;
}

std::vector<float> texelValues(const BtfInfo& i, int64_t t) {
  std::vector<float> v(i.texelBytes() / 4);
  for (size_t k = 0; k < v.size(); ++k) v[k] = float(t) * 100 + float(k) * 0.25f;
  return v;
}

void writeAll(const std::string& path, const BtfInfo& info) {
  BtfWriter w(path, info, false);
  w.writeVmf(std::vector<float>(size_t(info.nDirs()) * info.texels() * 2, 0.5f));
  for (int c = 0; c < info.chunks(); ++c) {
    std::vector<float> data;
    for (int64_t t = info.chunkBegin(c); t < info.chunkEnd(c); ++t) {
      auto v = texelValues(info, t);
      data.insert(data.end(), v.begin(), v.end());
    }
    w.writeChunk(c, data.data());
  }
  w.finish();
}

TEST(BtfStore, RoundTripOfTexelsImagesAndVmf) {
  const auto dir = test::tempDir("store_rt");
  const BtfInfo info = smallInfo();
  const std::string path = (dir / "a.btf").string();
  writeAll(path, info);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  BtfReader r(path);
  EXPECT_EQ(r.info().nu, 5);
  EXPECT_EQ(r.info().chunks(), 4);
  EXPECT_EQ(std::filesystem::file_size(path), r.layout().totalBytes);
  for (int64_t t = 0; t < info.texels(); ++t) EXPECT_EQ(r.readTexel(t), texelValues(info, t));
  const auto img = r.readImage(1, 0);  // view 1, light 0 → element (1 * 2 + 0) * 3
  for (int64_t t = 0; t < info.texels(); ++t)
    EXPECT_EQ(img[size_t(t) * 3 + 1], texelValues(info, t)[7]);
  EXPECT_EQ(r.readVmf(1)[3], 0.5f);
  const auto v = r.verify();
  EXPECT_TRUE(v.badChunks.empty());
  EXPECT_TRUE(v.vmfOk);
}

TEST(BtfStore, FlippedByteIsDetected) {
  const auto dir = test::tempDir("store_flip");
  const BtfInfo info = smallInfo();
  const std::string path = (dir / "a.btf").string();
  writeAll(path, info);
  const uint64_t off = BtfReader(path).layout().chunkOffset(info, 2) + 5;
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(off));
    char c;
    f.get(c);
    f.seekp(std::streamoff(off));
    f.put(char(c ^ 0x10));
  }
  BtfReader r(path);
  EXPECT_EQ(r.verify().badChunks, std::vector<int>{2});
  try {
    r.readChunk(2);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("chunk 2 checksum mismatch"), std::string::npos);
  }
  // A flipped header byte makes the file unreadable with a clear message.
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);
    f.put('#');
  }
  try {
    BtfReader bad(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("header checksum mismatch"), std::string::npos)
        << e.what();
  }
}

TEST(BtfStore, TruncatedAndForeignFilesAreErrors) {
  const auto dir = test::tempDir("store_trunc");
  const std::string path = (dir / "a.btf").string();
  writeAll(path, smallInfo());
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 7);
  try {
    BtfReader r(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "x.btf") << "!DFMF08FCR this is somebody else's container format";
  try {
    BtfReader r((dir / "x.btf").string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad magic"), std::string::npos);
  }
}

TEST(BtfStore, UnfinishedWriteLeavesNoFinalFile) {
  const auto dir = test::tempDir("store_unfinished");
  const BtfInfo info = smallInfo();
  const std::string path = (dir / "a.btf").string();
  {
    BtfWriter w(path, info, false);
    auto v = texelValues(info, 0);
    std::vector<float> data;
    for (int t = 0; t < 4; ++t) {
      auto x = texelValues(info, t);
      data.insert(data.end(), x.begin(), x.end());
    }
    w.writeChunk(0, data.data());
    EXPECT_THROW(w.finish(), Error);  // chunks missing
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::exists(path + ".partial"));
  BtfWriter resumed(path, info, true);
  EXPECT_TRUE(resumed.resumed());
  EXPECT_EQ(resumed.chunksDone(), 1);
  // A partial from other settings is refused for resume.
  BtfInfo other = info;
  other.seed = 2;
  EXPECT_THROW(BtfWriter(path, other, true), Error);
}

TEST(BtfStore, KilledSimulationResumesToTheSameBytes) {
  const auto dir = test::tempDir("store_resume");
  const std::string scene = test::sourceDir() + "/resources/scenes/brick.json";
  const std::string common = " --texels 8 --dirs bonn81 --spp 2 --chunk-texels 8 -q";
  std::string out;
  ASSERT_EQ(
      test::runBtfsim("simulate " + scene + " -o " + (dir / "full.btf").string() + common, &out), 0)
      << out;
  const std::string part = (dir / "cut.btf").string();
  // The test hook exits abruptly (no cleanup) after writing 2 chunks, like a kill.
  const int rc = test::runBtfsim("simulate " + scene + " -o " + part + common, &out,
                                 "BTF_TEST_ABORT_AFTER_CHUNKS=2");
  EXPECT_EQ(rc, 75) << out;
  EXPECT_FALSE(std::filesystem::exists(part));
  ASSERT_TRUE(std::filesystem::exists(part + ".partial"));
  ASSERT_EQ(
      test::runBtfsim("simulate " + scene + " -o " + part + common + " --resume --json", &out), 0)
      << out;
  EXPECT_NE(out.find("\"chunks_resumed\": 2"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(part + ".partial"));
  EXPECT_EQ(test::readFile(part), test::readFile(dir / "full.btf"));
  BtfReader r(part);
  EXPECT_GT(r.info().chunks(), 2);
}

}  // namespace
}  // namespace btf
