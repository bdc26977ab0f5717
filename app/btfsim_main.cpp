// btfsim: the engine from the command line (docs/cli.md). Every command's options come from its
// declaration in the engine (btf/ops): argv becomes a Request, the Report becomes text on stdout
// (notes and warnings on stderr) or JSON with --json. Errors are one line `btfsim: error: …`.
#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/ops/ops.h>
#include <btf/scene/scene.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>
#ifdef BTF_HAVE_MPI
#include <mpi_comm.h>
#include <sched.h>
#endif

namespace {

using btf::ops::CommandDecl;

struct Bound {
  std::map<std::string, std::string> values;
  std::map<std::string, std::vector<std::string>> lists;  // repeatable options (--pair)
  std::map<std::string, bool> flags;
};

std::string help(const CommandDecl& c, const btf::ParamDecl& d) {
  std::string s = d.doc;
  if (d.type == btf::ParamType::Int || d.type == btf::ParamType::Float) {
    const char* f = d.type == btf::ParamType::Int ? "%.0f" : "%.10g";
    char lo[32], hi[32], def[32];
    std::snprintf(lo, sizeof lo, f, d.min);
    std::snprintf(hi, sizeof hi, f, d.max);
    std::snprintf(def, sizeof def, f, d.def.at(0));
    s += std::string(" [") + (d.minExclusive ? "(" : "") + lo + ".." + hi;
    if (!c.sceneKeys.count(d.name)) s += std::string("; default ") + def;
    s += "]";
  } else if (d.type == btf::ParamType::Enum) {
    s += " [";
    for (size_t i = 0; i < d.choices.size(); ++i) s += (i ? "|" : "") + d.choices[i];
    if (!c.sceneKeys.count(d.name) && !d.defStr.empty()) s += "; default " + d.defStr;
    s += "]";
  } else if (!d.defStr.empty()) {
    s += " [default " + d.defStr + "]";
  }
  return s;
}

int writeText(const std::string& s, const std::string& output) {
  if (output.empty()) {
    std::cout << s;
    return 0;
  }
  std::ofstream f(output, std::ios::binary);
  if (!f || !(f << s)) throw btf::Error(output + ": cannot write");
  return 0;
}

// This executable's own bytes: ranks of one job must run the same build.
std::string selfFingerprint() {
  std::ifstream f("/proc/self/exe", std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return btf::hex64(btf::checksum64(ss.str()));
}

}  // namespace

int main(int argc, char** argv) {
  namespace ops = btf::ops;
  CLI::App app{"btfsim — simulate Bidirectional Texture Functions from micro-geometry"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "btfsim 0.2.0");

  std::map<std::string, Bound> bound;
  std::map<std::string, CLI::App*> subs;
  for (const CommandDecl& c : ops::commands()) {
    CLI::App* sub = app.add_subcommand(c.name, c.doc);
    subs[c.name] = sub;
    Bound& b = bound[c.name];
    for (const auto& d : c.options) {
      const std::string h = help(c, d);
      const bool positional =
          std::find(c.positional.begin(), c.positional.end(), d.name) != c.positional.end();
      std::string names = ops::optionName(c, d.name);
      if (positional) names = d.name;
      if (d.name == "output") names = "-o," + names;
      if (d.name == "quiet") names = "-q," + names;
      CLI::Option* o = nullptr;
      if (d.type == btf::ParamType::Bool)
        o = sub->add_flag(names, b.flags[d.name], h);
      else if (d.repeatable)
        o = sub->add_option(names, b.lists[d.name], h + " (repeatable)");
      else
        o = sub->add_option(names, b.values[d.name], h);
      if (d.type != btf::ParamType::Bool)
        o->type_name(d.type == btf::ParamType::Int     ? "INT"
                     : d.type == btf::ParamType::Float ? "NUMBER"
                     : d.type == btf::ParamType::Enum  ? "CHOICE"
                     : d.type == btf::ParamType::Path  ? "PATH"
                                                       : "TEXT");
      if (d.required) o->required();
    }
  }
  std::string schemaOut, schemaCommand, docOut, cliDocOut;
  bool quietAux = false, jsonAux = false;
  auto* sc = app.add_subcommand("schema",
                                "print a JSON Schema: the scene file's, or a command's "
                                "request with --command");
  sc->add_option("--command", schemaCommand, "the command whose request schema to print");
  sc->add_option("-o,--output", schemaOut, "write to this file instead of stdout");
  auto* sd =
      app.add_subcommand("scene-doc", "print the markdown reference of every scene parameter");
  sd->add_option("-o,--output", docOut, "write to this file instead of stdout");
  auto* cd = app.add_subcommand("cli-doc", "print the generated option tables of docs/cli.md");
  cd->add_option("-o,--output", cliDocOut, "write to this file instead of stdout");
  for (auto* a : {sc, sd, cd}) {
    a->add_flag("-q,--quiet", quietAux, "(accepted for uniformity; these print no progress)");
    a->add_flag("--json", jsonAux, "(accepted for uniformity; the output is the document)");
  }

  // An unknown command gets the same one-line message as every other error.
  if (argc > 1 && argv[1][0] != '-') {
    const std::string name = argv[1];
    if (!subs.count(name) && name != "schema" && name != "scene-doc" && name != "cli-doc") {
      std::fprintf(stderr,
                   "btfsim: error: unknown command '%s' (expected one of simulate, compress, "
                   "compare, export, plan, bench, study, brdf, slice, info, schema, scene-doc, "
                   "cli-doc; see btfsim --help)\n",
                   name.c_str());
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
    std::fprintf(stderr, "btfsim: error: %s (see btfsim --help)\n", what.c_str());
    return 2;
  }
  try {
    if (*sc)
      return writeText(
          schemaCommand.empty() ? btf::sceneJsonSchema() : ops::requestSchema(schemaCommand),
          schemaOut);
    if (*sd) return writeText(btf::sceneParamsMarkdown(), docOut);
    if (*cd) return writeText(ops::commandsMarkdown(), cliDocOut);
    for (const CommandDecl& c : ops::commands()) {
      CLI::App* sub = subs[c.name];
      if (!*sub) continue;
      ops::Request req(c.name);
      const Bound& b = bound[c.name];
      try {
        for (const auto& d : c.options) {
          const bool positional =
              std::find(c.positional.begin(), c.positional.end(), d.name) != c.positional.end();
          const std::string opt = positional ? d.name : ops::optionName(c, d.name);
          if (sub->count(opt) == 0) continue;
          if (d.type == btf::ParamType::Bool) {
            req.setFlag(d.name, b.flags.at(d.name));
          } else if (d.repeatable) {
            std::string joined;
            for (const auto& p : b.lists.at(d.name)) joined += (joined.empty() ? "" : ";") + p;
            req.set(d.name, joined);
          } else {
            req.set(d.name, b.values.at(d.name));
          }
        }
        req.validate();
      } catch (const btf::Error& e) {
        std::fprintf(stderr, "btfsim: error: %s\n", e.what());
        return 2;
      }
      const bool quiet = req.b("quiet"), json = req.b("json");
      btf::RunContext ctx;
      // Under mpirun or srun (an MPI build): one job over every rank (docs/cluster.md). Rank 0
      // alone prints; each rank takes its share of the node's cores.
      std::unique_ptr<btf::Comm> mpi;
#ifdef BTF_HAVE_MPI
      if (btf::launchedByMpi()) {
        auto m = std::make_unique<btf::MpiComm>(&argc, &argv);
        if (!req.given("threads") && m->localSize() > 1) {
          cpu_set_t set;
          const int affinity = sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 1;
          const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
          ctx.threads = std::max(1, std::min(affinity, hw / m->localSize()));
        }
        mpi = std::move(m);
        ctx.comm = mpi.get();
      }
#endif
      const bool root = !mpi || mpi->rank() == 0;
      ctx.progress = !quiet && root;
      const ops::NoteSink notes = [quiet, root](const std::string& s) {
        if (root && (!quiet || s.rfind("btfsim: warning:", 0) == 0))
          std::fprintf(stderr, "%s\n", s.c_str());
      };
      ops::Report rep;
      try {
        if (mpi) {
          btf::requireSame(*mpi, "the btfsim binary", selfFingerprint());
          btf::requireSame(*mpi, "the request", req.toJson());
        }
        rep = ops::run(req, ctx, notes);
      } catch (const btf::CollectiveError& e) {
        // Every rank failed together: rank 0 says why, each ends cleanly.
        if (root) std::fprintf(stderr, "btfsim: error: %s\n", e.what());
        return 1;
      } catch (const btf::Error& e) {
        if (!mpi || mpi->size() == 1) {
          std::fprintf(stderr, "btfsim: error: %s\n", e.what());
          return 1;
        }
#ifdef BTF_HAVE_MPI
        // This rank alone: the others may wait in a collective, so the job ends here.
        std::fprintf(stderr, "btfsim: error: rank %d of %d: %s\n", mpi->rank(), mpi->size(),
                     e.what());
        std::fflush(stderr);
        static_cast<btf::MpiComm*>(mpi.get())->abort(1);
#endif
      }
      if (!root) return 0;
      if (json)
        std::cout << rep.json.dump(2) << std::endl;
      else
        std::cout << rep.text << std::flush;
      return 0;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "btfsim: error: %s\n", e.what());
    return 1;
  }
  return 1;
}
