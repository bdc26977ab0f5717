// CLI conventions a user can rely on: every command takes -q and --json and its JSON validates
// against docs/schemas/COMMAND.json; argument errors are one line; the generated parts of
// docs/cli.md and the request schemas are current; exact angles; image metadata.
#include <btf/ops/ops.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "test_util.h"

namespace btf {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string scenePath(const std::string& n) {
  return test::sourceDir() + "/resources/scenes/" + n + ".json";
}

struct CliRun {
  int rc = -1;
  std::string out, err;
};

// stdout and stderr apart (test::runBtfsim merges them).
CliRun btfsim(const std::string& args, const fs::path& dir) {
  const fs::path errFile = dir / "stderr.txt";
  const std::string cmd = std::string(BTF_BTFSIM) + " " + args + " 2>" + errFile.string();
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = test::readFile(errFile);
  return r;
}

// A small JSON Schema validator: type, properties, required, additionalProperties (false or a
// schema), items, enum, const, minimum. Enough for the report schemas of docs/schemas/.
void validate(const json& v, const json& s, const std::string& at, std::vector<std::string>* errs) {
  auto typeOk = [&](const std::string& t) {
    if (t == "object") return v.is_object();
    if (t == "array") return v.is_array();
    if (t == "string") return v.is_string();
    if (t == "integer") return v.is_number_integer();
    if (t == "number") return v.is_number();
    if (t == "boolean") return v.is_boolean();
    if (t == "null") return v.is_null();
    return false;
  };
  if (s.contains("type")) {
    bool ok = false;
    if (s["type"].is_array())
      for (const auto& t : s["type"]) ok |= typeOk(t);
    else
      ok = typeOk(s["type"]);
    if (!ok) {
      errs->push_back(at + ": expected " + s["type"].dump() + ", got " + v.dump().substr(0, 60));
      return;
    }
  }
  if (s.contains("const") && v != s["const"]) errs->push_back(at + ": not " + s["const"].dump());
  if (s.contains("enum") && std::find(s["enum"].begin(), s["enum"].end(), v) == s["enum"].end())
    errs->push_back(at + ": " + v.dump() + " not in " + s["enum"].dump());
  if (s.contains("minimum") && v.is_number() && v.get<double>() < s["minimum"].get<double>())
    errs->push_back(at + ": below the minimum");
  if (v.is_object()) {
    for (const auto& k : s.value("required", json::array()))
      if (!v.contains(k)) errs->push_back(at + ": missing '" + k.get<std::string>() + "'");
    const json props = s.value("properties", json::object());
    for (auto it = v.begin(); it != v.end(); ++it) {
      if (props.contains(it.key()))
        validate(it.value(), props[it.key()], at + "/" + it.key(), errs);
      else if (s.contains("additionalProperties")) {
        const json& ap = s["additionalProperties"];
        if (ap.is_boolean() && !ap.get<bool>())
          errs->push_back(at + ": unexpected key '" + it.key() + "'");
        else if (ap.is_object())
          validate(it.value(), ap, at + "/" + it.key(), errs);
      }
    }
  }
  if (v.is_array() && s.contains("items"))
    for (size_t i = 0; i < v.size(); ++i)
      validate(v[i], s["items"], at + "/" + std::to_string(i), errs);
}

json schemaOf(const std::string& command) {
  const fs::path p = fs::path(test::sourceDir()) / "docs/schemas" / (command + ".json");
  std::ifstream f(p);
  if (!f) throw std::runtime_error(p.string() + ": missing report schema");
  return json::parse(f);
}

TEST(CliConventions, EveryCommandTakesQuietAndJsonAndMatchesItsSchema) {
  const auto dir = test::tempDir("cli_conv");
  const std::string d = dir.string();
  const std::string brick = scenePath("brick");
  const std::string sim = "simulate " + brick + " -o " + d + "/b.btf --texels 8 --dirs 4x8";
  struct Case {
    std::string command, args;
  } cases[] = {
      {"simulate", sim},
      {"simulate",
       "simulate " + brick + " -o " + d + "/s.cbtf --texels 8 --dirs 4x8 --compress svd"},
      {"info", "info " + d + "/b.btf"},
      {"info", "info " + d + "/s.cbtf"},
      {"simulate",
       "simulate " + brick + " -o " + d + "/t.cbtf --texels 8 --dirs 4x8 --compress tensor"},
      {"info", "info " + d + "/t.cbtf --bench-decoder"},
      {"compress", "compress " + d + "/b.btf -o " + d + "/b.cbtf --codec svd --compare"},
      {"compare", "compare " + d + "/b.btf " + d + "/b.cbtf --maps " + d + "/maps"},
      {"compare", "compare " + d + "/b.btf " + d + "/b.cbtf --noise " + d + "/b.btf"},
      {"export", "export " + d + "/b.cbtf --format merl -o " + d + "/b.merl --phi-samples 2"},
      {"export", "export " + d + "/b.btf --format ubo2014 -o " + d + "/b.dfmf --components 2"},
      {"export", "export " + d + "/t.cbtf --format ubo2014 -o " + d + "/t.dfmf"},
      {"export",
       "export " + d + "/b.btf --format ubo2003 --image-format jpg --zip -o " + d + "/b_jpg.zip"},
      {"slice", "slice " + d + "/b.cbtf --view 0,0 --light 30,0 -o " + d + "/v.png"},
      {"slice", "slice " + d + "/b.btf --texel avg --light 30,0 -o " + d + "/h.exr --size 16"},
      {"render", "render " + d + "/b.btf -o " + d + "/r.png --mode all --size 16 --spp 1"},
      {"render", "render " + d + "/b.btf -o " + d + "/r.exr --size 16 --spp 1 --reference " + d +
                     "/r.exact.exr --object section"},
      {"render", "render " + d + "/b.cbtf -o " + d + "/rc.exr --size 16 --spp 1 --vmf " + d +
                     "/b.btf --projection perspective"},
      {"plan", "plan " + brick + " --texels 8 --dirs 4x8"},
      {"bench", "bench " + brick + " --texels 4 --dirs 2x4 --repeat 1 --shadows map"},
      {"brdf", "brdf " + brick + " --pair 30,0,30,180 --pair 10,0,0,0 --spp 4 --method direct"},
      {"study", "study " + brick + " -o " + d +
                    "/st --texels 2 --dirs 2x4 --spp 1 --shadows map "
                    "--network-voxels 0 --gather 4 --links 16 --bounces 1 --reference-spp 8 "
                    "--image-spp 1 --image-paths 1"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    const CliRun r = btfsim(c.args + " -q --json", dir);
    ASSERT_EQ(r.rc, 0) << r.err;
    EXPECT_EQ(r.err.find("ETA"), std::string::npos) << "-q printed a bar: " << r.err;
    json j;
    ASSERT_NO_THROW(j = json::parse(r.out)) << r.out;
    std::vector<std::string> errs;
    validate(j, schemaOf(c.command), c.command, &errs);
    for (const auto& e : errs) ADD_FAILURE() << e;
    // The request is echoed with every declared option.
    ASSERT_TRUE(j.contains("request"));
    EXPECT_TRUE(j["request"]["quiet"].get<bool>());
  }
}

TEST(CliConventions, ArgumentErrorsAreOneLineWithTheOptionAndItsRange) {
  const auto dir = test::tempDir("cli_conv_err");
  const std::string brick = scenePath("brick");
  struct Case {
    std::string args, expect;
  } cases[] = {
      {"frobnicate", "unknown command 'frobnicate'"},
      {"slice x.btf -o x.png --light 1,2 --bogus", "--bogus"},
      {"simulate " + brick + " -o x.btf --spp 0", "--spp: must be in 1..64 (got 0)"},
      {"simulate " + brick + " -o x.btf --links 0", "--links: must be in 1..256 (got 0)"},
      {"simulate " + brick + " -o x.btf --shadows soft", "--shadows: must be one of map, rays"},
      {"compress x.btf -o y.cbtf --codec zip",
       "--codec: must be one of nmf, svd, perview, lpca, tensor"},
      {"export x.btf -o y --format obj", "--format: must be one of ubo2003, ubo2014, merl"},
      {"export x.btf -o y --format ubo2003 --image-format tiff",
       "--image-format: must be one of exr, png, jpg"},
      {"simulate " + brick, "--output is required"},
      {"slice x.btf -o x.tif --light 1,2 --view 0,0", "x.btf"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    const CliRun r = btfsim(c.args, dir);
    EXPECT_NE(r.rc, 0);
    EXPECT_EQ(r.err.rfind("btfsim: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << r.err;
  }
}

TEST(CliConventions, GeneratedDocsAndRequestSchemasAreCurrent) {
  const std::string cli = test::readFile(fs::path(test::sourceDir()) / "docs/cli.md");
  EXPECT_NE(cli.find(ops::commandsMarkdown()), std::string::npos)
      << "docs/cli.md is stale: regenerate with scripts/gen-docs.sh";
  for (const auto& c : ops::commands()) {
    SCOPED_TRACE(c.name);
    const fs::path p = fs::path(test::sourceDir()) / "docs/schemas/requests" / (c.name + ".json");
    EXPECT_EQ(test::readFile(p), ops::requestSchema(c.name))
        << p << " is stale: regenerate with scripts/gen-docs.sh";
    EXPECT_TRUE(fs::exists(fs::path(test::sourceDir()) / "docs/schemas" / (c.name + ".json")))
        << "no report schema for " << c.name;
    // Every option is documented.
    for (const auto& o : c.options) EXPECT_FALSE(o.doc.empty()) << o.name;
  }
}

TEST(CliConventions, StoredAnglesAreExactAndImagesCarryMetadata) {
  const auto dir = test::tempDir("cli_conv_meta");
  const std::string d = dir.string();
  CliRun r = btfsim(
      "simulate " + scenePath("brick") + " -o " + d + "/b.btf --texels 4 --dirs bonn81 -q", dir);
  ASSERT_EQ(r.rc, 0) << r.err;
  r = btfsim("info " + d + "/b.btf --json", dir);
  ASSERT_EQ(r.rc, 0) << r.err;
  const json j = json::parse(r.out);
  const auto& dirs = j["directions"]["theta_phi_deg"];
  ASSERT_EQ(dirs.size(), 81u);
  std::set<double> thetas;
  for (const auto& a : dirs) {
    thetas.insert(a[0].get<double>());
    for (int k = 0; k < 2; ++k) {
      const double v = a[k].get<double>();
      EXPECT_EQ(v, std::round(v * 1e6) / 1e6) << v;  // 15, not 14.999999999999998
    }
  }
  for (double t : {0.0, 15.0, 30.0, 45.0, 60.0, 75.0}) EXPECT_EQ(thetas.count(t), 1u) << t;
  // EXR: units, the pair and the scene hash as attributes; PNG: an sRGB chunk.
  r = btfsim("slice " + d + "/b.btf --view 0,0 --light 30,0 -o " + d + "/v.exr -q", dir);
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string exr = test::readFile(dir / "v.exr");
  for (const std::string key :
       {"btf:units", "btf:view_theta_phi_deg", "btf:light_theta_phi_deg", "btf:scene_hash"})
    EXPECT_NE(exr.find(key), std::string::npos) << key;
  EXPECT_NE(exr.find(j["scene_hash"].get<std::string>()), std::string::npos);
  r = btfsim("slice " + d + "/b.btf --view 0,0 --light 30,0 -o " + d + "/v.png -q", dir);
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string png = test::readFile(dir / "v.png");
  EXPECT_NE(png.find("sRGB"), std::string::npos);
  // Undocumented image types are refused with the path.
  r = btfsim("slice " + d + "/b.btf --view 0,0 --light 30,0 -o " + d + "/v.tif -q", dir);
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("unsupported image type '.tif'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "v.tif"));
}

TEST(CliConventions, NonTerminalBarsPrintEachLineOnceAndNoWildEta) {
  const auto dir = test::tempDir("cli_conv_bar");
  const CliRun r = btfsim("simulate " + scenePath("brick") + " -o " + (dir / "b.btf").string() +
                              " --texels 8 --dirs 4x8",
                          dir);
  ASSERT_EQ(r.rc, 0) << r.err;
  std::istringstream in(r.err);
  std::string line;
  std::map<std::string, int> full;
  while (std::getline(in, line)) {
    const auto bar = line.find("] ");
    if (line.find(" elapsed") == std::string::npos || bar == std::string::npos) continue;
    const double pct = std::stod(line.substr(bar + 2));
    if (pct >= 100) ++full[line.substr(0, 14)];
    // A stage shorter than a second prints its final line only: a line before 100 % comes
    // after a second of the stage.
    if (pct < 100) {
      const auto e0 = line.find("%  ", bar), e1 = line.find(" elapsed");
      ASSERT_NE(e0, std::string::npos) << line;
      const std::string el = line.substr(e0 + 3, e1 - e0 - 3);
      if (el.find("min") == std::string::npos && el.find(" h ") == std::string::npos) {
        EXPECT_GE(std::stod(el), 1.0) << line;
      }
    }
    if (pct < 5) {
      EXPECT_NE(line.find("ETA …"), std::string::npos) << line;
    }
  }
  EXPECT_FALSE(full.empty());
  for (const auto& [stage, n] : full) EXPECT_EQ(n, 1) << stage;
  EXPECT_EQ(r.err.find("(? free)"), std::string::npos);
}

}  // namespace
}  // namespace btf
