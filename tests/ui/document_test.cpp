// The editor's data model: every edit goes through the engine's parser, refused edits leave the
// scene as it was, and undo/redo over long random sequences returns the same canonical JSON.
#include <btf/core/error.h>
#include <gtest/gtest.h>
#include <ui/document.h>

#include <nlohmann/json.hpp>
#include <random>

#include "test_util.h"

using namespace btf;
using namespace btf::ui;
using namespace btf::test;
using json = nlohmann::ordered_json;

namespace {
Document brick() {
  Document d;
  d.open(sourceDir() + "/resources/scenes/brick.json");
  return d;
}
}  // namespace

TEST(Document, EditUndoRedoRestoresTheCanonicalJson) {
  Document d = brick();
  const std::string original = d.json();
  d.set("/parts/1/size", json::array({0.46, 0.21, 0.2}));
  EXPECT_NE(d.json(), original);
  EXPECT_NEAR(d.scene().parts[1].params.v3("size").z, 0.2, 1e-6);
  EXPECT_TRUE(d.dirty());
  d.undo();
  EXPECT_EQ(d.json(), original);
  EXPECT_FALSE(d.dirty());
  d.redo();
  EXPECT_NEAR(d.scene().parts[1].params.v3("size").z, 0.2, 1e-6);
}

TEST(Document, InvalidEditsNameThePathAndKeepTheScene) {
  Document d = brick();
  const std::string before = d.json();
  try {
    d.set("/parts/1/size", json::array({0.46, 0.21, -1.0}));
    FAIL() << "a negative size was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("parts[1].size"), std::string::npos) << e.what();
  }
  EXPECT_THROW(d.set("/parts/7/height", 1.0), Error);
  EXPECT_THROW(d.set("/materials/brick/exponent", "shiny"), Error);
  EXPECT_THROW(d.edit("remove the brick material", [](json& j) { j["materials"].erase("brick"); }),
               Error);  // a part still uses it
  EXPECT_EQ(d.json(), before);
  EXPECT_FALSE(d.canUndo());
}

TEST(Document, DragsMergeIntoOneUndoStep) {
  Document d = brick();
  const std::string original = d.json();
  for (int k = 1; k <= 10; ++k) d.set("/parts/0/height", 0.001 * k, "drag height", /*merge=*/k > 1);
  EXPECT_EQ(d.undoDepth(), 1u);
  d.undo();
  EXPECT_EQ(d.json(), original);
}

TEST(Document, LongRandomEditSequenceUndoesAndRedoesExactly) {
  Document d = brick();
  std::mt19937_64 rng(42);
  std::vector<std::string> states = {d.json()};
  const char* ptrs[] = {
      "/parts/0/height",           "/parts/1/center",          "/parts/1/size",
      "/materials/brick/exponent", "/materials/mortar/albedo", "/parts/1/array/row_shift"};
  std::uniform_real_distribution<double> f(0.05, 0.5);
  int accepted = 0;
  for (int i = 0; i < 300; ++i) {
    const std::string p = ptrs[rng() % 6];
    json v = d.get(p);
    if (v.is_array())
      for (auto& x : v) x = f(rng);
    else
      v = p.find("exponent") != std::string::npos ? 1 + 100 * f(rng) : f(rng);
    if (rng() % 5 == 0) {  // structural edits too: duplicate and remove a part
      d.edit("duplicate", [](json& j) { j["parts"].push_back(j["parts"][1]); });
    } else {
      try {
        d.set(p, v);
      } catch (const Error&) {
        continue;
      }
    }
    if (d.json() != states.back()) {
      states.push_back(d.json());
      ++accepted;
    }
  }
  ASSERT_GT(accepted, 200);
  ASSERT_EQ(d.undoDepth(), states.size() - 1);
  for (size_t k = states.size() - 1; k > 0; --k) {
    ASSERT_EQ(d.json(), states[k]);
    d.undo();
  }
  EXPECT_EQ(d.json(), states.front());
  for (size_t k = 1; k < states.size(); ++k) {
    d.redo();
    ASSERT_EQ(d.json(), states[k]);
  }
  // A new edit after undo drops the redo branch.
  d.undo();
  d.set("/parts/0/height", 0.0123);
  EXPECT_FALSE(d.canRedo());
}

TEST(Document, SaveIsAtomicAndRoundTrips) {
  Document d = brick();
  d.set("/materials/brick/exponent", 33.0);
  const auto dir = tempDir("ui_doc_save");
  const auto path = dir / "brick2.json";
  d.save(path);
  EXPECT_FALSE(d.dirty());
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".partial"));
  Document e;
  e.open(path);
  EXPECT_EQ(e.json(), d.json());
  EXPECT_THROW(e.save(dir / "no_such_folder" / "x.json"), Error);
  EXPECT_EQ(e.json(), d.json());
}
