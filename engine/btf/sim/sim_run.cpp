// The simulation run: chunk scheduling (over threads and a cluster's ranks, split chunks for few
// missing ones), the kernel over each chunk, and writing and resuming the store.
#include "texel_kernel.h"

namespace btf {

using namespace simdetail;

namespace {

// A cluster job's unit of work (docs/cluster.md): a whole chunk, or views [v0, v1) of a chunk
// when fewer chunks are missing than twice the ranks.
struct ViewPiece {
  int chunk = 0, v0 = 0, v1 = 0;
};
struct SplitChunk {
  int chunk = 0, owner = 0;  // owner: the rank of its first piece; it writes the chunk
};

// Every rank computes the same assignment from the same maps and done flags.
void assignWork(const BtfInfo& info, const HitMaps& maps, int nu, int nD, const BtfWriter* writer,
                const Comm& comm, std::vector<uint8_t>& mine, std::vector<ViewPiece>& pieces,
                std::vector<SplitChunk>& splits) {
  const int K = maps.grid().spp;
  struct Work {
    double cost;
    ViewPiece p;
  };
  std::vector<std::vector<double>> viewCost;  // per missing chunk, per view
  std::vector<int> missing;
  for (int c = 0; c < info.chunks(); ++c) {
    mine[size_t(c)] = 0;
    if (writer && writer->chunkDone(c)) continue;
    std::vector<double> w(size_t(nD), 0.0);
    for (int64_t t = info.chunkBegin(c); t < info.chunkEnd(c); ++t) {
      const int i = int(t % nu), j = int(t / nu);
      for (int d = 0; d < nD; ++d)
        w[size_t(d)] +=
            maps.hasEdgeTables() && maps.edgeCount(d, i * K, (i + 1) * K, j * K, (j + 1) * K) ? 5.0
                                                                                              : 1.0;
    }
    missing.push_back(c);
    viewCost.push_back(std::move(w));
  }
  const int R = comm.size(), M = int(missing.size());
  // Pieces per chunk: enough for about four per rank when the chunks alone are too few.
  const int P = M > 0 && M < 2 * R ? std::min(nD, (4 * R + M - 1) / M) : 1;
  std::vector<Work> work;
  for (int m = 0; m < M; ++m) {
    const std::vector<double>& w = viewCost[size_t(m)];
    double total = 0;
    for (double x : w) total += x;
    // Contiguous view ranges of about equal cost, none empty.
    int v0 = 0;
    double acc = 0;
    for (int k = 0; k < P; ++k) {
      int v1 = nD;
      if (k < P - 1) {
        v1 = v0;
        const double target = total * double(k + 1) / double(P);
        while (v1 < nD - (P - 1 - k) && (v1 == v0 || acc + w[size_t(v1)] <= target))
          acc += w[size_t(v1++)];
      }
      double c = 0;
      for (int v = v0; v < v1; ++v) c += w[size_t(v)];
      work.push_back({c, {missing[size_t(m)], v0, v1}});
      v0 = v1;
    }
  }
  std::stable_sort(work.begin(), work.end(),
                   [](const Work& a, const Work& b) { return a.cost > b.cost; });
  std::vector<double> load(size_t(R), 0.0);
  std::vector<int> owner(size_t(info.chunks()), -1);
  for (const Work& x : work) {
    const int q = int(std::min_element(load.begin(), load.end()) - load.begin());
    load[size_t(q)] += x.cost;
    if (x.p.v0 == 0) owner[size_t(x.p.chunk)] = q;
    if (q != comm.rank()) continue;
    if (P == 1)
      mine[size_t(x.p.chunk)] = 1;
    else
      pieces.push_back(x.p);
  }
  if (P > 1)
    for (int c : missing) splits.push_back({c, owner[size_t(c)]});
  std::sort(pieces.begin(), pieces.end(), [](const ViewPiece& a, const ViewPiece& b) {
    return a.chunk != b.chunk ? a.chunk < b.chunk : a.v0 < b.v0;
  });
}

}  // namespace

SimReport SimulationJob::run(const std::string& outPath, const SimEstimate& est,
                             const CancelToken* cancel) {
  if (!est.refusal.empty()) throw Error(est.refusal);
  SimReport r;
  r.output = outPath;
  const auto start = Clock::now();
  const EffectPlan& pl = plan();
  const bool pt = m_opt.method == "pt";
  const bool gi = !pt && pl.interreflection;
  const BtfInfo info = storeInfo(est.chunkTexels);
  Comm& comm = m_comm ? *m_comm : localComm();
  const bool dist = comm.distributed();
  const uint64_t comm0 = comm.bytesSent() + comm.bytesReceived();
  std::unique_ptr<BtfWriter> writer;
  if (!outPath.empty() && !dist) writer = std::make_unique<BtfWriter>(outPath, info, m_opt.resume);
  if (!outPath.empty() && dist) {
    // Rank 0 creates or resumes (and verifies) the partial; then the others open it, and learn
    // from rank 0 which chunks are done.
    collectively(comm, [&] {
      if (comm.root()) writer = std::make_unique<BtfWriter>(outPath, info, m_opt.resume);
    });
    collectively(comm, [&] {
      if (!comm.root()) writer = std::make_unique<BtfWriter>(outPath, info, BtfWriter::Attach{});
    });
    std::string done;
    if (comm.root()) done.assign(writer->doneFlags().begin(), writer->doneFlags().end());
    comm.broadcast(done, 0);
    if (!comm.root()) writer->setDone(std::vector<uint8_t>(done.begin(), done.end()));
  }
  std::vector<uint8_t> mine(size_t(info.chunks()), 1);  // this rank's chunks (after the maps)
  r.ranks = comm.size();
  r.chunks = info.chunks();
  r.chunksResumed = writer ? writer->chunksDone() : 0;
  if (writer) r.resumeNote = writer->resumeNote();
  if (m_network && gi) {
    r.networkSeconds = m_networkReused ? 0 : m_network->buildSeconds();
    r.networkReused = m_networkReused;
    r.networkPoints = m_network->points().size();
    r.networkLinks = m_network->links().size();
  }

  SampleGrid grid{m_opt.nu, m_opt.nv, m_mapSpp, m_scene.Lx, m_scene.Ly, m_opt.seed};
  HitMaps maps;
  {
    ProgressReporter pr("hit maps", m_dirs.size(), m_opt.progress);
    maps.build(*m_tracer, m_dirs, grid, &pr, cancel);
    if (m_adaptive) maps.buildEdgeTables(m_geom, cancel);
    pr.finish();
  }
  r.hitMapSeconds = since(start);
  r.hitMapRays = maps.raysTraced();
  // A cluster job's work: the missing chunks, by estimated cost, largest first to the least
  // loaded rank (every rank computes the same assignment from the same maps). When fewer chunks
  // are missing than twice the ranks, each is cut into pieces of contiguous views (cut at equal
  // cost) so that no rank idles; a split chunk's pieces are gathered on the rank of its first
  // piece, which writes (or encodes) it. Cost: one per (texel, view), four more where the view's
  // map has an edge in the texel's footprint — where adaptive sampling refines.
  std::vector<ViewPiece> pieces;   // this rank's pieces of split chunks
  std::vector<SplitChunk> splits;  // every split chunk, in chunk order
  if (dist)
    assignWork(info, maps, m_opt.nu, m_dirs.size(), writer.get(), comm, mine, pieces, splits);
  r.precomputeSeconds = r.hitMapSeconds + (gi ? r.networkSeconds : 0);
  throwIfCancelled(cancel, "hit maps");
  const int nD = m_dirs.size();
  if ((writer && comm.root()) || m_vmfSink) {
    std::vector<float> vmf;
    if (info.hasVmf) {
      vmf.reserve(size_t(nD) * size_t(info.texels()) * 2);
      for (int d = 0; d < nD; ++d) {
        auto v = maps.vmf(d);
        vmf.insert(vmf.end(), v.begin(), v.end());
      }
    }
    if (writer && comm.root()) writer->writeVmf(vmf);
    if (m_vmfSink && !vmf.empty()) m_vmfSink(std::move(vmf));  // every rank: the same maps
  }

  if (m_exact && !m_exact->prepared()) {
    const auto t = Clock::now();
    ProgressReporter pr("exact visibility", nD, m_opt.progress);
    m_exact->prepare(&pr, cancel);
    pr.finish();
    r.exactSeconds = since(t);
  }
  r.visibility = visibilityName();
  if (m_exact) {
    // Blocks of rows per view from what the budget leaves (at most 1 GiB): chunks of a row or
    // two then share each face's clipping (the same bits).
    const uint64_t spare = m_opt.memoryBudget > est.memoryBytes ? m_opt.memoryBudget - est.memoryBytes : 0;
    m_exact->setRowCache(std::min<uint64_t>(spare / 2, 1ull << 30));
  }
  struct DropRows {
    ExactDirect* ex;
    ~DropRows() {
      if (ex) ex->setRowCache(0);
    }
  } dropRows{m_exact.get()};
  const ShadowMode mode = pl.selfShadowing ? m_opt.shadows : ShadowMode::None;
  DirectIllumination direct(*m_tracer, m_materials, m_dirs, maps,
                            {mode, m_opt.shadowBias, m_opt.grazingRays});
  if (m_exact) direct.skipTriangles(m_exact->shadedMask());
  NetworkLighting lighting;
  lighting.setClosedFormTail(pl.closedFormTail);
  std::unique_ptr<NetworkGather> gather;
  const auto renderStart = Clock::now();
  if (gi) {
    // A cluster job: each rank solves every R-th light and the ranks then share the solutions
    // (a copy of each light's rows: the same arrays as one process; docs/cluster.md).
    const int parts = dist ? comm.size() : 1, part = dist ? comm.rank() : 0;
    ProgressReporter pr("network light", int(NetworkLighting::lightsOfPart(nD, part, parts).size()),
                        m_opt.progress);
    lighting.solve(
        *m_network, m_geom, m_materials, m_dirs,
        [&](int l, const Vec3& p, const Vec3& ng, uint32_t prim) {
          return direct.lightVisibility(l, p, ng, prim);
        },
        pl.bounces, glossyGather(), &pr, cancel, -1, part, parts);
    pr.finish();
    r.lightsSolved = lighting.solvedLights();
    if (dist) {
      const auto t = Clock::now();
      // Test hook: the share's round size in bytes per rank (1: one light a round).
      const char* round = std::getenv("BTF_TEST_LIGHT_SHARE_ROUND_BYTES");
      r.giShareBytes = lighting.share(
          comm, round ? std::max<uint64_t>(1, std::strtoull(round, nullptr, 10)) : uint64_t(64) << 20);
      r.lightShareSeconds = since(t);
    }
    r.lightSeconds = lighting.solveSeconds() + r.lightShareSeconds;
    gather =
        std::make_unique<NetworkGather>(*m_network, lighting, m_geom, m_materials, m_tracer.get());
    throwIfCancelled(cancel, "network light");
    if (m_opt.reciprocalGather) {
      const auto t = Clock::now();
      ProgressReporter rp("reciprocal gather", nD, m_opt.progress);
      // A cluster job: each rank sums a share of the views, and every rank gets every view's
      // sums (and occluded fractions), counted with the light share. The hits' occluded
      // fractions are kept for the texels' gather when they fit in a sixteenth of the memory
      // budget (one byte per hit-map sample).
      std::vector<uint8_t> occ;
      const bool keep = uint64_t(nD) * uint64_t(maps.grid().samples()) <= m_opt.memoryBudget / 16;
      const uint64_t c0 = comm.bytesSent() + comm.bytesReceived();
      const ReciprocalScale rs = reciprocalScale(
          gatherTileSums(*gather, maps, m_geom, m_dirs, comm, &rp, cancel, keep ? &occ : nullptr),
          nD);
      r.giShareBytes += comm.bytesSent() + comm.bytesReceived() - c0;
      rp.finish();
      gather->setScale(rs.scale);
      if (!occ.empty()) gather->setOcclusionCache(std::move(occ), maps.grid().samples());
      r.reciprocalSeconds = since(t);
      r.reciprocalMaxCorrection = rs.maxCorrection;
    }
  }
  TexelKernel kernel{*m_tracer, m_materials, m_dirs, maps, direct, gather.get(),
                     pt,        nullptr,     {},     1,    {}};
  AdaptiveStats adStats;
  std::unique_ptr<AdaptiveTexelSampler> adaptive;
  if (m_adaptive) {
    adaptive = std::make_unique<AdaptiveTexelSampler>(*m_tracer, m_materials, m_dirs, maps, direct,
                                                      gather.get(), m_opt.adaptiveSettings,
                                                      m_onlyTrainingTexels ? nullptr : &adStats);
    kernel.adaptive = adaptive.get();
  }
  kernel.exact = m_exact.get();
  kernel.ptPaths = m_opt.ptPaths;
  kernel.pt.maxBounces = pl.interreflection ? pl.bounces : 1;
  kernel.pt.seed = m_opt.seed;
  for (const auto& d : m_dirs.dirs()) kernel.lights.push_back(DVec3(Vec3(d.w)));

  // Test hooks: a kill after N chunks (of rank BTF_TEST_ABORT_RANK only, when set).
  const char* abortEnv = std::getenv("BTF_TEST_ABORT_AFTER_CHUNKS");
  const char* abortRank = std::getenv("BTF_TEST_ABORT_RANK");
  const int abortAfter =
      abortEnv && (!abortRank || std::atoi(abortRank) == comm.rank()) ? std::atoi(abortEnv) : -1;
  int written = 0;
  // Two buffers: chunk c is written by a background task while chunk c + 1 is computed.
  std::vector<float> buffers[2];
  int cur = 0;
  std::future<double> pending;  // the background write; returns its duration
  auto waitWrite = [&] {
    if (!pending.valid()) return;
    r.writeSeconds += pending.get();
    if (++written == abortAfter) {
      std::fprintf(stderr, "\nBTF_TEST_ABORT_AFTER_CHUNKS: exiting abruptly after %d chunk(s)\n",
                   written);
      if (std::getenv("BTF_TEST_ABORT_KILL")) std::raise(SIGKILL);  // as `kill -9` would
      std::_Exit(75);
    }
  };
  std::atomic<uint64_t> evals{0};
  if (!m_trainTexels.empty() && m_trainSink) {
    const int64_t n = int64_t(m_trainTexels.size());
    const size_t stride = size_t(nD) * size_t(nD) * 3;
    std::vector<float> values(size_t(n) * stride, 0.f);
    // A cluster job: rank r computes the training texels r, r + N, …, then every rank gets all.
    const int64_t R = comm.size(), me = comm.rank();
    const int64_t myN = n / R + (me < n % R ? 1 : 0);
    std::vector<float> local(size_t(myN) * stride, 0.f);
    ProgressReporter tp("training texels", myN, m_opt.progress);
    if (kernel.exact) {
      // Exact visibility: one item per view, every training texel of this rank at once (a
      // texel at a time would prepare the whole view for each).
      std::vector<int64_t> mineT(static_cast<size_t>(myN));
      for (int64_t k = 0; k < myN; ++k) mineT[size_t(k)] = m_trainTexels[size_t(k * R + me)];
      std::atomic<int64_t> viewsDone{0};
      parallelForChunks(
          nD, 1,
          [&](int64_t b, int64_t e) {
            std::vector<float*> rows(static_cast<size_t>(myN));
            for (int64_t v = b; v < e; ++v) {
              for (int64_t k = 0; k < myN; ++k)
                rows[size_t(k)] = &local[size_t(k) * stride + size_t(v) * nD * 3];
              kernel.evalExactTexels(mineT.data(), size_t(myN), int(v), rows.data());
              const int64_t before = viewsDone.fetch_add(1);
              tp.add((before + 1) * myN / nD - before * myN / nD);
            }
          },
          cancel);
    } else {
      parallelForChunks(
          myN * nD, pt ? 1 : 8,
          [&](int64_t b, int64_t e) {
            for (int64_t k = b; k < e; ++k) {
              const int64_t t = m_trainTexels[size_t((k / nD) * R + me)];
              const int view = int(k % nD);
              kernel.eval(int(t % m_opt.nu), int(t / m_opt.nu), view,
                          &local[size_t(k / nD) * stride + size_t(view) * nD * 3]);
              if (view == nD - 1) tp.add(1);
            }
          },
          cancel);
    }
    throwIfCancelled(cancel, "training texels");
    tp.finish();
    if (!dist) {
      values.swap(local);
    } else {
      const std::vector<std::string> all = comm.allgather(
          std::string(reinterpret_cast<const char*>(local.data()), local.size() * sizeof(float)));
      for (int64_t q = 0; q < R; ++q) {
        const float* src = reinterpret_cast<const float*>(all[size_t(q)].data());
        for (int64_t i = q, j = 0; i < n; i += R, ++j)
          std::copy(src + size_t(j) * stride, src + size_t(j + 1) * stride,
                    values.begin() + ptrdiff_t(size_t(i) * stride));
      }
    }
    m_trainSink(values.data());
    if (m_onlyTrainingTexels) {
      r.wallSeconds = since(start);
      return r;
    }
  }
  int64_t myTexels = 0;
  for (int c = 0; c < info.chunks(); ++c)
    if (mine[size_t(c)] && !(writer && writer->chunkDone(c)))
      myTexels += info.chunkEnd(c) - info.chunkBegin(c);
  for (const ViewPiece& p : pieces) myTexels += info.chunkEnd(p.chunk) - info.chunkBegin(p.chunk);
  ProgressReporter pr("aBRDF", dist ? myTexels : info.texels(), m_opt.progress);
  const auto evalStart = Clock::now();
  const size_t stride = size_t(nD) * size_t(nD) * 3;  // floats per texel
  // Views [v0, v1) of texels [t0, t1) into `out` (texel t's view v at (t − t0)·texelStride +
  // (v − v0)·nD·3). Work items: (block of B texels, view); B > 1 only for the plain direct kernel.
  auto computeViews = [&](int64_t t0, int64_t t1, int v0, int v1, float* out, size_t texelStride) {
    if (kernel.exact) {
      // Exact visibility: one item per view, every texel of the chunk and every light.
      const int64_t nv = v1 - v0, n = t1 - t0;
      std::atomic<int64_t> viewsDone{0};
      parallelForChunks(
          nv, 1,
          [&](int64_t b, int64_t e) {
            uint64_t local = 0;
            for (int64_t k = b; k < e; ++k) {
              local += uint64_t(kernel.evalExactView(t0, t1, v0 + int(k), v0, out, texelStride));
              const int64_t before = viewsDone.fetch_add(1);
              pr.add((before + 1) * n / nv - before * n / nv);
            }
            evals += local;
          },
          cancel);
      r.abrdfValues += uint64_t(n) * uint64_t(nv) * uint64_t(nD);
      r.texelsComputed += double(n) * double(nv) / double(nD);
      return;
    }
    const int B = kernel.blockTexels();
    const int64_t blocks = (t1 - t0 + B - 1) / B, nv = v1 - v0;
    // The texel-by-texel kernels go view by view over the texels: neighbouring texels seen from
    // one view read neighbouring parts of each light's map (shadow-map taps, edge tables, block
    // maxima), so consecutive items share cache lines. Progress counts a texel per nv items.
    const bool viewMajor = B == 1 && !pt;
    std::atomic<int64_t> itemsDone{0};
    parallelForChunks(
        blocks * nv, viewMajor ? 32 : 1,
        [&](int64_t b, int64_t e) {
          uint64_t local = 0;
          for (int64_t k = b; k < e; ++k) {
            const int64_t tb = t0 + (viewMajor ? k % blocks : k / nv) * B;
            const int n = int(std::min<int64_t>(B, t1 - tb));
            const int view = v0 + int(viewMajor ? k / blocks : k % nv);
            local += uint64_t(kernel.evalBlock(
                tb, n, m_opt.nu, view,
                out + size_t(tb - t0) * texelStride + size_t(view - v0) * nD * 3, texelStride));
            if (!viewMajor && view == v1 - 1) pr.add(n);
          }
          if (viewMajor) {
            const int64_t before = itemsDone.fetch_add(e - b);
            pr.add((before + e - b) / nv - before / nv);
          }
          evals += local;
        },
        cancel);
    r.abrdfValues += uint64_t(t1 - t0) * uint64_t(nv) * uint64_t(nD);
    r.texelsComputed += double(t1 - t0) * double(nv) / double(nD);
  };
  // This rank's pieces of split chunks, each texel's views [v0, v1) contiguous.
  std::vector<std::vector<float>> pieceValues(pieces.size());
  // On one rank, a failure ends the run here; in a cluster job every rank first reaches the
  // agreement below (so none waits forever), then all fail with the failing rank's message.
  collectively(comm, [&] {
    for (int c = 0; c < info.chunks(); ++c) {
      const int64_t t0 = info.chunkBegin(c), t1 = info.chunkEnd(c);
      if (!mine[size_t(c)]) continue;
      if (writer && writer->chunkDone(c)) {
        pr.add(t1 - t0);
        continue;
      }
      ++r.chunksComputed;
      std::vector<float>& chunk = buffers[cur];
      chunk.assign(size_t(t1 - t0) * stride, 0.f);
      computeViews(t0, t1, 0, nD, chunk.data(), stride);
      if (cancel && cancel->cancelled()) {
        waitWrite();  // the chunk in flight lands in the .partial; then the one outcome
        throw Cancelled("aBRDF");
      }
      if (m_sink) m_sink(c, t0, t1, chunk.data());
      if (writer) {
        waitWrite();  // at most one write in flight: the other buffer is free again
        pending = std::async(std::launch::async, [&writer, c, data = chunk.data()] {
          const auto w0 = Clock::now();
          writer->writeChunk(c, data);
          return since(w0);
        });
        cur ^= 1;
      }
    }
    waitWrite();
    for (size_t i = 0; i < pieces.size(); ++i) {
      const ViewPiece& p = pieces[i];
      const int64_t t0 = info.chunkBegin(p.chunk), t1 = info.chunkEnd(p.chunk);
      const size_t ps = size_t(p.v1 - p.v0) * size_t(nD) * 3;
      pieceValues[i].assign(size_t(t1 - t0) * ps, 0.f);
      computeViews(t0, t1, p.v0, p.v1, pieceValues[i].data(), ps);
      throwIfCancelled(cancel, "aBRDF");
    }
    r.rankEvalSeconds = since(evalStart);  // this rank's own work, before the agreement
  });
  if (!splits.empty()) {
    // Split chunks: every rank sends its pieces of chunk c to c's owner (one gather per chunk,
    // in chunk order, every rank taking part), which assembles, encodes and writes it.
    std::vector<std::pair<int, std::vector<float>>> assembled;
    for (const SplitChunk& sc : splits) {
      std::string mineBytes;
      for (size_t i = 0; i < pieces.size(); ++i) {
        if (pieces[i].chunk != sc.chunk) continue;
        const int32_t range[2] = {pieces[i].v0, pieces[i].v1};
        mineBytes.append(reinterpret_cast<const char*>(range), sizeof range);
        mineBytes.append(reinterpret_cast<const char*>(pieceValues[i].data()),
                         pieceValues[i].size() * sizeof(float));
        std::vector<float>().swap(pieceValues[i]);
      }
      const std::vector<std::string> got = comm.gather(mineBytes, sc.owner);
      if (comm.rank() != sc.owner) continue;
      const int64_t t0 = info.chunkBegin(sc.chunk), t1 = info.chunkEnd(sc.chunk);
      std::vector<float> chunk(size_t(t1 - t0) * stride, 0.f);
      int covered = 0;
      for (const std::string& g : got) {
        size_t o = 0;
        while (o < g.size()) {
          int32_t range[2];
          BTF_CHECK(g.size() - o >= sizeof range);
          std::memcpy(range, g.data() + o, sizeof range);
          o += sizeof range;
          BTF_CHECK(range[0] >= 0 && range[0] < range[1] && range[1] <= nD);
          const size_t ps = size_t(range[1] - range[0]) * size_t(nD) * 3;
          BTF_CHECK(g.size() - o >= size_t(t1 - t0) * ps * sizeof(float));
          for (int64_t t = t0; t < t1; ++t)
            std::memcpy(&chunk[size_t(t - t0) * stride + size_t(range[0]) * nD * 3],
                        g.data() + o + size_t(t - t0) * ps * sizeof(float), ps * sizeof(float));
          o += size_t(t1 - t0) * ps * sizeof(float);
          covered += range[1] - range[0];
        }
      }
      BTF_CHECK(covered == nD);  // every view of the chunk, once
      assembled.push_back({sc.chunk, std::move(chunk)});
    }
    collectively(comm, [&] {
      for (const auto& [c, chunk] : assembled) {
        ++r.chunksComputed;
        if (m_sink) m_sink(c, info.chunkBegin(c), info.chunkEnd(c), chunk.data());
        if (writer) writer->writeChunk(c, chunk.data());
      }
    });
  }
  pr.finish();
  // Writes overlap the compute: the time spent waiting for the last one is not compute.
  r.evalSeconds = since(evalStart);
  r.renderSeconds = since(renderStart);
  r.brdfEvaluations = evals.load();
  if (dist) {
    // The job's totals, on every rank.
    std::vector<double> sums = {double(r.abrdfValues), double(r.brdfEvaluations)};
    if (m_adaptive) {
      const std::vector<double> a = adStats.toVector();
      sums.insert(sums.end(), a.begin(), a.end());
    }
    sums = sumInRankOrder(comm, sums);
    r.abrdfValues = uint64_t(sums[0]);
    r.brdfEvaluations = uint64_t(sums[1]);
    if (m_adaptive) adStats.assign(std::vector<double>(sums.begin() + 2, sums.end()));
  }
  if (m_adaptive) {
    r.adaptive = true;
    r.samplingJson = adStats.json();
    r.samplingText = adStats.histogramText();
    r.meanSamples = adStats.meanSamples();
    r.estimatedError = adStats.estimatedRelativeError();
  }
  if (writer) {
    // In a cluster job every rank's chunks are in the file once all have passed the agreement
    // above; rank 0 checks the table and renames.
    collectively(comm, [&] {
      if (!dist)
        writer->finish();
      else if (comm.root())
        writer->finishShared();
    });
    r.outputBytes = btfFileBytes(info);
  }
  // The chunks' traffic (agreements, sums, split chunks' pieces); the GI share apart.
  r.commBytes = comm.bytesSent() + comm.bytesReceived() - comm0 - r.giShareBytes;
  r.wallSeconds = since(start);
  r.peakRssBytes = peakRssBytes();
  return r;
}

}  // namespace btf
