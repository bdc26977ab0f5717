// The Embree device both tracers open (periodic tile, ordinary mesh): its errors collected as one
// message for a btf::Error. Internal to the engine's .cpp files (it includes rtcore.h).
#pragma once
#include <btf/core/error.h>
#include <embree3/rtcore.h>

#include <mutex>
#include <string>

namespace btf {

struct EmbreeErrors {
  std::mutex mutex;
  std::string message;  // the first error, "" while none
};

inline void onEmbreeError(void* user, RTCError code, const char* str) {
  auto* e = static_cast<EmbreeErrors*>(user);
  std::lock_guard lock(e->mutex);
  if (e->message.empty())
    e->message = "Embree error " + std::to_string(int(code)) + ": " + (str ? str : "");
}

/// A device on every core whose errors land in `errors`; throws btf::Error when none opens.
inline RTCDevice newEmbreeDevice(EmbreeErrors* errors) {
  RTCDevice d = rtcNewDevice("threads=0");
  if (!d) throw Error("cannot create the Embree device");
  rtcSetDeviceErrorFunction(d, onEmbreeError, errors);
  return d;
}

}  // namespace btf
