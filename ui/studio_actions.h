// The studio's actions that panels may call (the App implements them): panels see this
// interface and their own state, not the App (panels/panels.h).
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace btf::ui {

class StudioActions {
 public:
  virtual ~StudioActions() = default;
  /// A status-bar message (errors in red); never throws.
  virtual void message(const std::string& text, bool error = false) = 0;
  virtual void setParam(const std::string& pointer, const nlohmann::ordered_json& value,
                        bool merge = false) = 0;
  virtual void undo() = 0;
  virtual void redo() = 0;
  virtual void requestPreview() = 0;
  virtual int startSimulation(const std::string& output, bool compressToo) = 0;
  virtual int startCompression(const std::string& input, const std::string& output) = 0;
  virtual int startStreamedSimulation(const std::string& output) = 0;
  virtual int startStudy(const std::string& dir) = 0;
  virtual int startExport(const std::string& input, const std::string& format,
                          const std::string& output) = 0;
  virtual void openCompressed(const std::string& path, const std::string& reference) = 0;
  /// `btfsim render` of the open compressed BTF on the Objects panel's object, view, light,
  /// tiling and relief scale (mode all, exact, mapped or flat; `size` pixels wide), as a job; its
  /// image and errors come back to the panel. The raw reference supplies the visibility map.
  /// `output` (a .png) defaults to the job form's folder, objects_MODE.png.
  virtual int startObjectRender(const std::string& mode, int spp, int size,
                                const std::string& output = "") = 0;
  virtual void compareInspector() = 0;
  virtual int startCodecSweep(const std::string& reference) = 0;
  virtual void loadStudy(const std::string& dir) = 0;
  virtual std::string simulationEstimate() = 0;
  /// Facts the script's report records (panel rectangles, latencies).
  virtual nlohmann::json& report() = 0;
};

}  // namespace btf::ui
