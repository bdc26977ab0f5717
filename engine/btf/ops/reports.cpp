// The typed reports as JSON: one serialiser per command, each writing its struct's fields in the
// order docs/schemas/COMMAND.json lists them (what `--json` has always printed).
#include <btf/ops/reports.h>

namespace btf::ops {

namespace {

Json pair(double a, double b) {
  return Json::array({a, b});
}
Json texels(int nu, int nv) {
  return Json::array({nu, nv});
}

void put(Json& j, const CodecFigures& f) {
  j["codec"] = f.params;
  j["stats"] = f.stats;
}

void putSizes(Json& j, const CodecFigures& f) {
  j["raw_bytes"] = f.rawBytes;
  j["compressed_bytes"] = f.compressedBytes;
  j["vmf_bytes"] = f.vmfBytes;
  j["ratio"] = f.ratio;
  j["peak_memory_bytes"] = f.peakMemoryBytes;
}

Json levelsJson(const std::vector<LevelFigures>& levels) {
  Json a = Json::array();
  for (const auto& e : levels)
    a.push_back({{"level", e.level},
                 {"texels", texels(e.nu, e.nv)},
                 {"relative_rmse", e.relRmse},
                 {"rmse", e.rmse}});
  return a;
}

Json json(const SimulateResult& r) {
  Json j;
  j["output"] = r.output;
  j["scene"] = r.scene;
  j["texels"] = texels(r.nu, r.nv);
  j["directions"] = r.directions;
  j["direction_count"] = r.directionCount;
  j["spp"] = r.spp;
  j["sampling"] = r.sampling;
  j["visibility"] = r.visibility;
  j["shadows"] = r.shadows;
  j["method"] = r.method;
  j["plan"] = r.plan;
  j["threads"] = r.threads;
  j["estimated_seconds"] = r.estimatedSeconds;
  if (r.cluster) j["cluster"] = toJson(*r.cluster);
  if (r.store) {
    const auto& s = *r.store;
    j["network_points"] = s.networkPoints;
    j["network_links"] = s.networkLinks;
    j["precompute_seconds"] = s.precomputeSeconds;
    j["render_seconds"] = s.renderSeconds;
    j["network_seconds"] = s.networkSeconds;
    j["network_reused"] = s.networkReused;
    j["network_light_seconds"] = s.networkLightSeconds;
    j["wall_seconds"] = s.wallSeconds;
    j["hit_map_seconds"] = s.hitMapSeconds;
    j["abrdf_seconds"] = s.abrdfSeconds;
    j["write_seconds"] = s.writeSeconds;
    j["exact_visibility_seconds"] = s.exactVisibilitySeconds;
    j["reciprocal_gather_seconds"] = s.reciprocalGatherSeconds;
    j["reciprocal_gather_max_correction"] = s.reciprocalGatherMaxCorrection;
    j["hit_map_rays"] = s.hitMapRays;
    j["rays_per_second"] = s.raysPerSecond;
    j["abrdf_values"] = s.abrdfValues;
    j["abrdf_evaluations_per_second"] = s.abrdfEvaluationsPerSecond;
    j["brdf_evaluations"] = s.brdfEvaluations;
    j["peak_memory_bytes"] = s.peakMemoryBytes;
    j["output_bytes"] = s.outputBytes;
    j["chunks"] = s.chunks;
    j["chunks_resumed"] = s.chunksResumed;
    if (r.samples) j["samples"] = *r.samples;
  }
  if (r.compressed) {
    const auto& s = *r.compressed;
    put(j, s.file);
    j["wall_seconds"] = s.wallSeconds;
    if (r.samples) j["samples"] = *r.samples;
    j["simulate_seconds"] = s.simulateSeconds;
    if (s.levelSeconds) j["level_seconds"] = *s.levelSeconds;
    j["encode_seconds"] = s.encodeSeconds;
    j["finish_seconds"] = s.finishSeconds;
    putSizes(j, s.file);
    if (s.levelSeconds) j["levels"] = levelsJson(s.levels);
  }
  return j;
}

Json json(const CompressResult& r) {
  Json j;
  if (r.cluster) j["cluster"] = toJson(*r.cluster);
  j["input"] = r.input;
  j["output"] = r.output;
  put(j, r.file);
  j["seconds"] = r.seconds;
  if (r.pyramid) j["level_seconds"] = r.pyramid->levelSeconds;
  j["train_seconds"] = r.trainSeconds;
  j["encode_seconds"] = r.encodeSeconds;
  j["finish_seconds"] = r.finishSeconds;
  j["raw_bytes"] = r.file.rawBytes;
  if (r.pyramid) j["pyramid_raw_bytes"] = r.pyramid->rawBytes;
  j["compressed_bytes"] = r.file.compressedBytes;
  j["vmf_bytes"] = r.file.vmfBytes;
  j["ratio"] = r.file.ratio;
  if (r.pyramid) j["pyramid_ratio"] = r.pyramid->ratio;
  j["peak_memory_bytes"] = r.file.peakMemoryBytes;
  if (r.pyramid) {
    // Level 0 against the input, measured with every level (--compare adds nothing more).
    const LevelFigures& l0 = r.pyramid->levels.at(0);
    j["error"] = {{"level", 0}, {"rmse", l0.rmse}, {"relative_rmse", l0.relRmse}};
    j["levels"] = levelsJson(r.pyramid->levels);
  } else if (r.error) {
    j["error"] = toJson(*r.error);
  }
  return j;
}

Json json(const CompareResult& r) {
  Json j = toJson(r.error);
  j["level"] = r.level;
  j["a"] = {{"path", r.a.path}, {"kind", r.a.kind}, {"ratio", r.a.ratio}};
  j["b"] = {{"path", r.b.path}, {"kind", r.b.kind}, {"ratio", r.b.ratio}};
  if (!r.maps.empty()) j["maps"] = r.maps;
  if (!r.bAtADirections.empty()) j["b_at_a_directions"] = r.bAtADirections;
  if (r.noise)
    j["noise"] = {{"path", r.noise->path},
                  {"floor_rmse", r.noise->floorRmse},
                  {"floor_relative_rmse", r.noise->floorRelRmse},
                  {"excess_relative_rmse", r.noise->excessRelRmse}};
  return j;
}

Json json(const ExportResult& r) {
  Json j;
  j["input"] = r.input;
  j["format"] = r.format;
  j["output"] = r.output;
  j["level"] = r.level;
  if (const auto* e = std::get_if<ExportResult::Ubo2003>(&r.details)) {
    j["images"] = e->images;
    j["image_format"] = e->imageFormat;
    j["zip"] = e->zip;
    if (e->scale) j["scale"] = *e->scale;
    if (e->clippedFraction) j["clipped_fraction"] = *e->clippedFraction;
  } else if (const auto* e = std::get_if<ExportResult::Ubo2014>(&r.details)) {
    j["bytes"] = e->bytes;
    j["components"] = {e->components[0], e->components[1], e->components[2]};
    j["factorisation_relative_rmse"] = e->factorisationRelRmse;
    j["export_relative_rmse"] = e->exportRelRmse;
  } else if (const auto* e = std::get_if<ExportResult::Merl>(&r.details)) {
    j["bins"] = e->bins;
    j["missing_bins"] = e->missingBins;
    j["anisotropy"] = e->anisotropy;
    j["asymmetry"] = e->asymmetry;
    j["asymmetry_max"] = e->asymmetryMax;
  } else if (const auto* e = std::get_if<ExportResult::Rgl>(&r.details)) {
    j["bytes"] = e->bytes;
    j["theta_i"] = e->thetaI;
    j["phi_i"] = e->phiI;
    j["resolution"] = e->resolution;
    j["ndf_projected_area"] = e->ndfProjectedArea;
  }
  return j;
}

Json json(const PlanResult& r) {
  Json j = r.plan;
  j["scene"] = r.scene;
  j["method"] = r.method;
  j["texels"] = texels(r.nu, r.nv);
  j["directions"] = r.directions;
  j["triangles"] = r.triangles;
  const auto& e = r.estimate;
  j["estimate"] = {{"seconds", e.seconds},
                   {"hit_map_seconds", e.hitMapSeconds},
                   {"abrdf_seconds", e.abrdfSeconds},
                   {"network_light_seconds", e.networkLightSeconds},
                   {"gather_seconds", e.gatherSeconds},
                   {"memory_bytes", e.memoryBytes},
                   {"network_bytes", e.networkBytes}};
  if (r.network)
    j["network"] = {{"points", r.network->points},
                    {"links", r.network->links},
                    {"voxels", r.network->voxels},
                    {"build_seconds", r.network->buildSeconds}};
  return j;
}

Json json(const BenchResult& r) {
  Json results = Json::array();
  for (const auto& m : r.results) {
    Json j;
    j["shadows"] = m.shadows;
    j["method"] = m.method;
    j["interreflection"] = m.interreflection;
    j["bounces"] = m.bounces;
    j["texels"] = texels(m.nu, m.nv);
    j["directions"] = m.directions;
    j["pairs"] = m.pairs;
    j["spp"] = m.spp;
    j["sampling"] = m.sampling;
    if (m.samples) j["samples"] = *m.samples;
    j["threads"] = m.threads;
    j["runs"] = m.runs;
    j["median_wall_seconds"] = m.medianWallSeconds;
    j["median_hit_map_seconds"] = m.medianHitMapSeconds;
    j["median_abrdf_seconds"] = m.medianAbrdfSeconds;
    j["median_rays_per_second"] = m.medianRaysPerSecond;
    j["median_abrdf_values_per_second"] = m.medianAbrdfValuesPerSecond;
    j["estimated_seconds"] = m.estimatedSeconds;
    j["peak_rss_bytes"] = m.peakRssBytes;
    j["memory_budget_bytes"] = m.memoryBudgetBytes;
    results.push_back(j);
  }
  Json j;
  j["scene"] = r.scene;
  j["results"] = results;
  return j;
}

Json json(const BrdfResult& r) {
  Json pairs = Json::array();
  for (const auto& p : r.pairs)
    pairs.push_back({{"theta_i", p.thetaI},
                     {"phi_i", p.phiI},
                     {"theta_o", p.thetaO},
                     {"phi_o", p.phiO},
                     {"abrdf", {p.abrdf[0], p.abrdf[1], p.abrdf[2]}}});
  Json j;
  j["scene"] = r.scene;
  j["method"] = r.method;
  j["bounces"] = r.bounces;
  j["samples"] = r.samples;
  j["pairs"] = pairs;
  return j;
}

Json json(const SliceResult& r) {
  Json j;
  j["input"] = r.input;
  j["output"] = r.output;
  j["light_theta_phi_deg"] = pair(r.light[0], r.light[1]);
  j["level"] = r.level;
  j["kind"] = r.kind;
  if (r.kind == "spatial")
    j["view_theta_phi_deg"] = pair(r.view[0], r.view[1]);
  else
    j["texel"] = r.texel;
  j["size"] = texels(r.width, r.height);
  return j;
}

Json json(const InfoResult& r) {
  Json j;
  j["path"] = r.path;
  j["format"] = r.format;
  j["scene"] = r.scene;
  j["scene_hash"] = r.sceneHash;
  j["texels"] = texels(r.nu, r.nv);
  Json dirs = Json::array();
  for (const auto& d : r.directionsDeg) dirs.push_back(pair(d[0], d[1]));
  j["directions"] = {{"set", r.directionSet}, {"count", r.directionCount}, {"theta_phi_deg", dirs}};
  j["file_bytes"] = r.fileBytes;
  j["verified"] = r.verified;
  if (const auto* c = std::get_if<InfoResult::Compressed>(&r.details)) {
    j["codec"] = c->codec;
    j["colour"] = c->colour;
    j["params"] = c->params;
    j["stats"] = c->stats;
    j["ratio"] = c->ratio;
    Json arrays = Json::array();
    for (const auto& x : c->arrays)
      arrays.push_back({{"name", x.name}, {"rows", x.rows}, {"cols", x.cols}, {"type", x.type}});
    j["arrays"] = arrays;
    if (!c->levels.empty()) {
      Json lv = Json::array();
      for (size_t k = 0; k < c->levels.size(); ++k) {
        const auto& l = c->levels[k];
        lv.push_back({{"level", k},
                      {"texels", texels(l.nu, l.nv)},
                      {"first", l.first},
                      {"relative_rmse", l.relRmse ? Json(*l.relRmse) : Json(nullptr)}});
      }
      j["levels"] = lv;
    }
    if (c->decoderBench)
      j["decoder_bench"] = {{"threads", 1},
                            {"random_values_per_s", c->decoderBench->randomValuesPerSecond},
                            {"texel_values_per_s", c->decoderBench->texelValuesPerSecond},
                            {"checksum", c->decoderBench->checksum}};
  } else if (const auto* w = std::get_if<InfoResult::Raw>(&r.details)) {
    j["tile_size"] = pair(w->Lx, w->Ly);
    j["chunk_texels"] = w->chunkTexels;
    j["chunks"] = w->chunks;
    j["spp"] = w->spp;
    j["shadows"] = w->shadows;
    j["shadow_bias"] = w->shadowBias;
    j["seed"] = w->seed;
    j["plan"] = w->plan;
    j["has_vmf"] = w->hasVmf;
    j["bad_chunks"] = w->badChunks;
    j["vmf_ok"] = w->vmfOk;
  }
  return j;
}

Json json(const RenderResult& r) {
  Json j;
  j["input"] = r.input;
  j["output"] = r.output;
  j["mode"] = r.mode;
  j["object"] = r.object;
  j["size"] = texels(r.width, r.height);
  j["spp"] = r.spp;
  j["tiling"] = r.tiling;
  j["relief_scale"] = r.reliefScale;
  j["filter"] = r.filter;
  if (r.texelLevels)
    j["texel_levels"] = {{"count", r.texelLevels->count},
                         {"from", r.texelLevels->from},
                         {"forced", r.texelLevels->forced},
                         {"max_aniso", r.texelLevels->maxAniso}};
  j["camera_theta_phi_deg"] = pair(r.camera[0], r.camera[1]);
  j["light_theta_phi_deg"] = pair(r.light[0], r.light[1]);
  j["irradiance"] = r.irradiance;
  j["environment"] = r.environment;
  j["projection"] = r.projection;
  j["world_per_tile_unit"] = r.worldPerTileUnit;
  j["shell"] = {{"prisms", r.prisms},
                {"faces", r.shellFaces},
                {"height_range_world", pair(r.heightRangeWorld[0], r.heightRangeWorld[1])}};
  if (r.mappedSpeedup) j["mapped_speedup"] = *r.mappedSpeedup;
  Json list = Json::array();
  for (const auto& im : r.images) {
    Json e;
    e["mode"] = im.mode;
    e["seconds"] = im.seconds;
    e["samples"] = im.samples;
    e["rays"] = im.rays;
    e["triangles"] = im.triangles;
    e["samples_per_second"] = im.seconds > 0 ? double(im.samples) / im.seconds : 0.0;
    if (im.footprint) {
      Json f;
      f["pixels"] = im.footprint->pixels;
      if (im.footprint->medianTexelsPerSample) {
        f["median_texels_per_sample"] = *im.footprint->medianTexelsPerSample;
        f["level_share"] = im.footprint->levelShare;
      }
      e["footprint"] = f;
    }
    e["output"] = im.output;
    if (im.error) e["error"] = toJson(*im.error);
    if (im.errorVsExact) e["error_vs_exact"] = toJson(*im.errorVsExact);
    list.push_back(e);
  }
  j["images"] = list;
  return j;
}

Json json(const StudyResult& r) {
  Json j;
  j["scene"] = r.scene;
  j["output"] = r.output;
  Json arr = Json::array();
  for (const auto& c : r.configurations)
    arr.push_back({{"config", c.config},
                   {"seconds", c.seconds},
                   {"probe_rel_rmse", c.probeRelRmse},
                   {"set_rel_rmse", c.setRelRmse},
                   {"image_rel_rmse", c.imageRelRmse},
                   {"pareto", c.pareto}});
  j["configurations"] = arr;
  if (r.compression) {
    Json a = Json::array();
    for (const auto& c : *r.compression)
      a.push_back({{"codec", c.codec},
                   {"beta", c.beta},
                   {"components", c.components},
                   {"ratio", c.ratio},
                   {"bytes", c.bytes},
                   {"rmse", c.rmse},
                   {"relative_rmse", c.relRmse},
                   {"psnr_db", c.psnrDb},
                   {"seconds", c.seconds},
                   {"pareto", c.pareto}});
    j["compression"] = a;
  }
  if (r.pyramid) {
    Json a = Json::array();
    for (const auto& p : *r.pyramid) {
      Json lv = Json::array();
      for (const auto& l : p.levels)
        lv.push_back({{"texels", texels(l.nu, l.nv)}, {"relative_rmse", l.relRmse}});
      a.push_back({{"codec", p.codec},
                   {"bytes", p.bytes},
                   {"size_vs_single_level", p.sizeVsSingleLevel},
                   {"level_seconds", p.levelSeconds},
                   {"seconds", p.seconds},
                   {"levels", lv}});
    }
    j["pyramid"] = a;
  }
  return j;
}

}  // namespace

Json toJson(const ClusterFigures& c) {
  Json ranks = Json::array();
  for (const auto& x : c.perRank)
    ranks.push_back({{"texels", x.texels},
                     {"data_bytes", x.dataBytes},
                     {"communicated_bytes", x.communicatedBytes},
                     {"communicated_fraction", x.communicatedFraction},
                     {"seconds", x.seconds},
                     {"lights_solved", x.lightsSolved},
                     {"gi_share_bytes", x.giShareBytes}});
  return {{"ranks", c.ranks},
          {"communicator", c.communicator},
          {"max_communicated_bytes", c.maxCommunicatedBytes},
          {"max_communicated_fraction", c.maxCommunicatedFraction},
          {"balance", c.balance},
          {"per_rank", ranks}};
}

Json toJson(const ErrorReport& e) {
  return Json::parse(errorReportJson(e));
}

Json toJson(const ImageError& e) {
  Json j;
  j["rel_rmse"] = e.relRmse;
  j["rel_rmse_interior"] = e.relRmseInterior;
  j["interior_pixels"] = e.interiorPixels;
  j["coverage_mismatch"] = e.coverageMismatch;
  j["reference_pixels"] = e.refPixels;
  j["mismatch_pixels"] = e.mismatchPixels;
  j["extra_pixels"] = e.extraPixels;
  return j;
}

Json toJson(const Result& r) {
  return std::visit(
      [](const auto& x) -> Json {
        if constexpr (std::is_same_v<std::decay_t<decltype(x)>, std::monostate>)
          return Json::object();
        else
          return json(x);
      },
      r);
}

}  // namespace btf::ops
