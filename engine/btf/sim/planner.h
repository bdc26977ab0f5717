// The effect planner: simulate only what the scene calls for. From the geometry, the materials,
// the direction set and the point network it decides self-shadowing/masking, inter-reflection,
// the path length P, the colour channels and the visibility map, each with its reason; flags
// force any of them. The plan goes into the BTF header and drives the estimate.
#pragma once
#include <btf/directions/direction_set.h>
#include <btf/scene/material.h>
#include <btf/sim/network.h>
#include <btf/trace/periodic_tracer.h>

#include <string>
#include <vector>

namespace btf {

enum class Toggle { Auto, On, Off };
Toggle parseToggle(const std::string& s, const std::string& what);
const char* toggleName(Toggle t);

struct PlanRequest {
  Toggle selfShadowing = Toggle::Auto;
  Toggle interreflection = Toggle::Auto;
  int bounces = 0;  // P when > 0 (forces it); 0 = from the energy bound, at most maxAutoBounces
  /// A time cap on the automatic P; reaching it is stated in the plan with the dropped tail.
  int maxAutoBounces = 12;
  double epsilon = 0.01;         // relative energy below which an inter-reflection order is dropped
  Toggle colour = Toggle::Auto;  // On = RGB, Off = one channel
  Toggle vmf = Toggle::Auto;
  Toggle glossyIndirect = Toggle::Auto;  // glossy lobes reflecting indirect light at the texels
  /// The orders past P: added in closed form (On; Auto when the plan chose P ≥ 3) or dropped.
  Toggle tail = Toggle::Auto;
};

struct EffectDecision {
  std::string effect;  // self_shadowing, interreflection, bounces, tail, glossy_indirect, …
  std::string value;   // on/off, a number
  std::string reason;
  bool forced = false;
  double secondsSaved = 0;  // filled by the job's estimate; negative: what the decision costs
};

struct EffectPlan {
  bool flat = false;
  bool selfShadowing = true;
  bool interreflection = false;
  int bounces = 1;  // P: reflections along a path (1 = direct only)
  int channels = 3;
  bool vmf = true;
  bool glossyIndirect = false;  // glossy receivers gather indirect light through their lobe
  double glossyAlbedo = 0;      // largest directional albedo of a glossy lobe alone
  double rhoMax = 0, alphaMax = 0, alphaMean = 0;
  double energyBound = 0;  // ρ_max·ᾱ: the decay of the inter-reflection orders
  double droppedTail = 0;  // Σ of the orders P leaves out, relative to the direct reflection
  /// The orders past P are added as a geometric series whose ratio is measured per light and
  /// channel from the last two computed orders (NetworkLighting::setClosedFormTail).
  bool closedFormTail = false;
  int64_t occlusionTests = 0, occludedTests = 0;
  std::vector<EffectDecision> decisions;
  EffectDecision* find(const std::string& effect);
  /// JSON of the plan; `withTimes` adds each decision's estimated saving (not deterministic, so
  /// the BTF header leaves it out: a resumed run must see the same header).
  std::string toJson(bool withTimes = true) const;
};

/// Decides every effect. `net` may be empty when no network was built (inter-reflection then
/// needs to be forced off); self-occlusion is probed from the network points (or, without
/// points, a 32×32 grid of the hit points of the vertical view) toward every direction of the set.
EffectPlan planEffects(const PeriodicTracer& tracer, const std::vector<Material>& materials,
                       const DirectionSet& dirs, const PointNetwork* net, const PlanRequest& req);

}  // namespace btf
