// btfsim: the engine from the command line (docs/cli.md). Argument parsing only; the commands
// live in commands.cpp. Errors print as one line on stderr with a nonzero exit.
#include <btf/core/error.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "commands.h"

namespace {
void addEffectOptions(CLI::App* c, btf::cli::EffectArgs& e) {
  c->add_option("--method", e.method, "network (direct + point-network GI) or pt (path traced)");
  c->add_option("--self-shadowing", e.selfShadowing, "auto, on or off");
  c->add_option("--interreflection", e.interreflection, "auto, on or off");
  c->add_option("--bounces", e.bounces, "P: reflections per path (1 = direct only; 0 = plan)");
  c->add_option("--epsilon", e.epsilon, "planner: energy fraction below which an order is dropped");
  c->add_option("--glossy-indirect", e.glossyIndirect,
                "auto, on or off: glossy lobes reflect the indirect light at the texels");
  c->add_option("--colour", e.colour, "auto, on (RGB) or off (one channel, grey scenes)");
  c->add_option("--vmf", e.vmf, "auto, on or off: store the visibility map");
  c->add_option("--network-voxels", e.networkVoxels, "network density (0 = one per texel)");
  c->add_option("--links", e.links, "network links per point");
  c->add_option("--gather", e.gather, "N1: network points per direct hit");
  c->add_option("--paths", e.paths, "--method pt: paths per texel sample");
}
void addCodecOptions(CLI::App* c, btf::cli::CodecArgs& a, bool withName) {
  if (withName) c->add_option("--codec", a.codec, "nmf (per-texel NMF + PCA), svd, perview, lpca");
  c->add_option("--colour-model", a.colourModel, "rgb or ycc (luminance + two chroma channels)");
  c->add_option("--components", a.components, "PCA components (0 = from the target)");
  c->add_option("--target-rmse", a.targetRmse, "relative RMSE target, e.g. 0.05 (default)");
  c->add_option("--target-ratio", a.targetRatio, "compression ratio target, e.g. 300");
  c->add_option("--beta", a.beta, "nmf: β of the per-texel rank rule (eq. 3.21)");
  c->add_option("--beta-mode", a.betaMode, "nmf: energy (Σσ²) or singular (Σσ, the thesis)");
  c->add_option("--solver", a.solver, "nmf: hals or mu (Lee-Seung multiplicative updates)");
  c->add_option("--max-rank", a.maxRank, "nmf: largest per-texel rank");
  c->add_option("--nmf-iterations", a.iterations, "nmf: iterations per texel at most");
  c->add_option("--train-texels", a.trainTexels, "svd/perview/lpca: training texels");
  c->add_option("--clusters", a.clusters, "lpca: k-means clusters");
  c->add_flag("--f32", a.f32, "store float32 arrays instead of float16");
}
}  // namespace

int main(int argc, char** argv) {
  using namespace btf::cli;
  CLI::App app{"btfsim — simulate Bidirectional Texture Functions from micro-geometry"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "btfsim 0.1.0");

  SimulateArgs sim;
  auto* s = app.add_subcommand("simulate", "simulate a raw BTF into a store file");
  s->add_option("scene", sim.scene, "scene file (JSON)")->required();
  s->add_option("-o,--output", sim.output, "output BTF store (written atomically)")->required();
  s->add_option("--dirs", sim.dirs, "direction set: bonn81, ubo151 or a θ×φ grid like 16x32");
  s->add_option("--texels", sim.texels, "texels: N or NUxNV");
  s->add_option("--spp", sim.spp, "K: K×K jittered rays per texel");
  s->add_option("--shadows", sim.shadows, "self-shadowing: map or rays");
  s->add_option("--bias", sim.bias, "shadow-map bias scale (default 1)");
  s->add_option("--threads", sim.threads, "worker threads (default: all cores)");
  s->add_option("--seed", sim.seed, "jitter seed");
  s->add_option("--memory-budget", sim.memoryBudget, "memory budget, e.g. 4G, 512M");
  s->add_option("--chunk-texels", sim.chunkTexels,
                "at most this many texels per chunk (resume granularity; 0 = from the budget)");
  addEffectOptions(s, sim.effects);
  s->add_option("--compress", sim.compress,
                "compress while simulating with this codec (nmf, svd, perview, lpca); the output "
                "is a .cbtf and no raw BTF is written");
  addCodecOptions(s, sim.codec, false);
  s->add_flag("--resume", sim.resume, "continue an interrupted run from OUTPUT.partial");
  s->add_flag("--json", sim.json, "print a JSON summary on stdout");
  s->add_flag("-q,--quiet", sim.quiet, "no progress bar");

  BrdfArgs br;
  auto* b = app.add_subcommand("brdf", "texel-averaged aBRDF at direction pairs, without a BTF");
  b->add_option("scene", br.scene, "scene file")->required();
  b->add_option("--pair", br.pairs, "θi,φi,θo,φo in degrees (repeatable)");
  b->add_option("--pairs", br.pairsFile, "CSV file of θi,φi,θo,φo lines");
  b->add_option("--spp", br.samples, "samples per axis over the tile (N×N rays per pair)");
  b->add_option("--method", br.method, "pt (path traced, every effect) or direct");
  b->add_option("--bounces", br.bounces, "pt: reflections per path (0 = unbounded)");
  b->add_option("--paths", br.paths, "pt: paths per sample position");
  b->add_option("--threads", br.threads, "worker threads");
  b->add_flag("--json", br.json, "JSON output");

  SliceArgs sl;
  auto* c = app.add_subcommand("slice",
                               "an image of a BTF: spatial (view, light) or a hemisphere of views");
  c->add_option("btf", sl.btf, "BTF store")->required();
  c->add_option("-o,--output", sl.output, "image file (.exr linear, .png tone mapped)")->required();
  c->add_option("--view", sl.view, "θ,φ of the view (degrees): spatial image");
  c->add_option("--light", sl.light, "θ,φ of the light (degrees)")->required();
  c->add_option("--texel", sl.texel, "u,v or avg: hemisphere image of aBRDF over views");
  c->add_option("--exposure", sl.exposure, "PNG: multiplies π·aBRDF before the sRGB curve");
  c->add_option("--size", sl.size, "hemisphere image size in pixels");

  InfoArgs in;
  auto* i = app.add_subcommand(
      "info", "print a BTF's header (raw or compressed) and verify every checksum");
  i->add_option("btf", in.btf, "BTF store")->required();
  i->add_flag("--json", in.json, "JSON output");

  BenchArgs be;
  auto* bn = app.add_subcommand("bench", "benchmark the simulator (compute only, nothing written)");
  bn->add_option("scene", be.scene, "scene file")->required();
  bn->add_option("--texels", be.texels, "texels");
  bn->add_option("--dirs", be.dirs, "direction set");
  bn->add_option("--spp", be.spp, "K");
  bn->add_option("--shadows", be.shadows, "comma-separated modes to measure");
  bn->add_option("--threads", be.threads, "worker threads");
  bn->add_option("--repeat", be.repeat, "runs per mode (the median is reported)");
  addEffectOptions(bn, be.effects);
  bn->add_flag("--json", be.json, "JSON output");

  PlanArgs pa;
  auto* pl =
      app.add_subcommand("plan", "print the effect plan of a scene with reasons and savings");
  pl->add_option("scene", pa.scene, "scene file")->required();
  pl->add_option("--dirs", pa.dirs, "direction set");
  pl->add_option("--texels", pa.texels, "texels");
  pl->add_option("--spp", pa.spp, "K");
  pl->add_option("--shadows", pa.shadows, "map or rays");
  pl->add_option("--threads", pa.threads, "worker threads");
  addEffectOptions(pl, pa.effects);
  pl->add_flag("--json", pa.json, "JSON output");

  StudyArgs st;
  auto* sy = app.add_subcommand("study", "accuracy vs time: sweep the knobs against a path tracer");
  sy->add_option("scene", st.scene, "scene file")->required();
  sy->add_option("-o,--output", st.output, "output folder (study.csv, study.md, study.svg)")
      ->required();
  sy->add_option("--texels", st.texels, "texels of every run");
  sy->add_option("--method", st.methods, "methods: network, pt (first = base)");
  sy->add_option("--paths", st.paths, "pt: paths per texel sample");
  sy->add_option("--dirs", st.dirs, "direction sets, comma-separated (first = base)");
  sy->add_option("--spp", st.spp, "K values");
  sy->add_option("--shadows", st.shadows, "shadow modes: map, rays");
  sy->add_option("--network-voxels", st.voxels, "network densities (0 = one per texel)");
  sy->add_option("--gather", st.gather, "N1 values");
  sy->add_option("--links", st.links, "links per network point");
  sy->add_option("--bounces", st.bounces, "path lengths P (1 = direct only)");
  sy->add_flag("--grid", st.grid, "full product of the lists instead of one knob at a time");
  sy->add_option("--reference-spp", st.referenceSpp, "reference paths per axis per probe pair");
  sy->add_option("--threads", st.threads, "worker threads");
  sy->add_flag("-q,--quiet", st.quiet, "no progress bar");
  sy->add_option("--codecs", st.codecs,
                 "compression knobs: codecs to compare on the base configuration's BTF");
  sy->add_option("--betas", st.betas, "nmf β values (comma-separated)");
  sy->add_option("--components", st.components, "component counts (0 = from the target)");
  sy->add_option("--target-ratio", st.codec.targetRatio, "codec target ratio (with --codecs)");
  sy->add_option("--target-rmse", st.codec.targetRmse, "codec target relative RMSE");
  sy->add_option("--colour-model", st.codec.colourModel, "rgb or ycc");

  CompressArgs ca;
  auto* cp = app.add_subcommand("compress", "compress a raw BTF store into a .cbtf");
  cp->add_option("input", ca.input, "raw BTF store")->required();
  cp->add_option("-o,--output", ca.output, "compressed file (.cbtf, written atomically)")
      ->required();
  addCodecOptions(cp, ca.codec, true);
  cp->add_option("--threads", ca.threads, "worker threads");
  cp->add_option("--memory-budget", ca.memoryBudget, "memory budget, e.g. 8G");
  cp->add_flag("--compare", ca.compare, "also measure the error against the input");
  cp->add_flag("--json", ca.json, "JSON summary on stdout");
  cp->add_flag("-q,--quiet", ca.quiet, "no progress bar");

  CompareArgs cm;
  auto* cmp = app.add_subcommand("compare", "error between two BTFs (raw or compressed)");
  cmp->add_option("a", cm.a, "reference BTF (.btf or .cbtf)")->required();
  cmp->add_option("b", cm.b, "BTF to measure (.btf or .cbtf)")->required();
  cmp->add_option("--maps", cm.maps, "folder for per-texel and per-direction error maps");
  cmp->add_option("--worst", cm.worst, "how many worst texels and directions to list");
  cmp->add_option("--threads", cm.threads, "worker threads");
  cmp->add_flag("--json", cm.json, "JSON output");
  cmp->add_flag("-q,--quiet", cm.quiet, "no progress bar");

  ExportArgs ex;
  auto* exc =
      app.add_subcommand("export", "export a BTF to the Bonn UBO2003/UBO2014 or MERL formats");
  exc->add_option("input", ex.input, "BTF (.btf or .cbtf)")->required();
  exc->add_option("--format", ex.format, "ubo2003, ubo2014 or merl")->required();
  exc->add_option("-o,--output", ex.output, "folder (ubo2003) or file")->required();
  exc->add_option("--components", ex.components, "ubo2014: components per channel");
  exc->add_option("--phi-samples", ex.phiSamples, "merl: half-vector azimuths averaged per bin");
  exc->add_option("--threads", ex.threads, "worker threads");
  exc->add_flag("-q,--quiet", ex.quiet, "no progress bar");

  std::string schemaOut;
  auto* sc = app.add_subcommand("schema", "print the scene file's JSON Schema");
  sc->add_option("-o,--output", schemaOut, "write to this file instead of stdout");

  std::string docOut;
  auto* sd =
      app.add_subcommand("scene-doc", "print the markdown reference of every scene parameter");
  sd->add_option("-o,--output", docOut, "write to this file instead of stdout");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (*s) return simulate(sim);
    if (*b) return brdf(br);
    if (*c) return slice(sl);
    if (*i) return info(in);
    if (*bn) return bench(be);
    if (*pl) return plan(pa);
    if (*sy) return study(st);
    if (*cp) return compress(ca);
    if (*cmp) return compare(cm);
    if (*exc) return exportBtf(ex);
    if (*sc) return schema(schemaOut);
    if (*sd) return sceneDoc(docOut);
  } catch (const btf::Error& e) {
    std::fprintf(stderr, "btfsim: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "btfsim: error: %s\n", e.what());
    return 1;
  }
  return 1;
}
