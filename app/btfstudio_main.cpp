// btfstudio: the BTF Studio desktop app. Thin: parses the arguments and runs btf::ui::App.
#include <btf/core/error.h>
#include <ui/app.h>

#include <CLI/CLI.hpp>
#include <cstdio>

int main(int argc, char** argv) {
  btf::ui::AppOptions o;
  CLI::App cli{"BTF Studio: author micro-geometry, preview, simulate, compress and view BTFs"};
  cli.add_option("scene", o.scene, "scene file to open (default: a flat Lambert tile)");
  cli.add_option("--script", o.script,
                 "run a JSON list of UI actions, then exit with their status (docs/studio.md)");
  cli.add_option("--screenshot", o.screenshot,
                 "save a PNG of the window once the preview has finished, then exit");
  cli.add_option("--width", o.width, "window width in pixels")->check(CLI::Range(320, 8192));
  cli.add_option("--height", o.height, "window height in pixels")->check(CLI::Range(240, 8192));
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e);
  }
  try {
    btf::ui::App app(o);
    return app.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "btfstudio: error: %s\n", e.what());
    return 1;
  }
}
