// Requests: the use cases of the engine (simulate, compress, compare, export, study, plan, bench,
// brdf, slice, info) declared once, like the scene's parameters (docs/architecture.md). One
// declaration gives the CLI's options and --help, the tables of docs/cli.md, the studio's job
// forms, validation (the option's name and range in every error) and the JSON echo of a request.
#pragma once
#include <btf/scene/params.h>

#include <map>
#include <set>
#include <string>
#include <vector>

namespace btf::ops {

struct CommandDecl {
  std::string name, doc;
  /// Positional arguments first (in `positional`), then options; every option's ParamDecl has
  /// its range, default and doc. Options named in `sceneKeys` default to the scene's
  /// "simulation" block (the request then leaves them unset).
  std::vector<ParamDecl> options;
  std::vector<std::string> positional;
  std::set<std::string> sceneKeys;
  const ParamDecl* find(const std::string& key) const;
};

/// Every command, in the order of docs/cli.md. Each has the common options threads, quiet, json.
const std::vector<CommandDecl>& commands();
/// Throws btf::Error naming the known commands.
const CommandDecl& command(const std::string& name);
/// "memory_budget" → "--memory-budget"; positional arguments are shown in capitals.
std::string optionName(const CommandDecl& c, const std::string& key);

/// A request: a command and its values. Every declared key has a value (its default) except the
/// scene-backed ones, which are present only when given.
class Request {
 public:
  explicit Request(const std::string& command);
  const CommandDecl& decl() const { return *m_decl; }
  const std::string& command() const { return m_decl->name; }
  /// Parses `text` by the option's type and checks its range or choices; throws btf::Error
  /// "--spp: must be in 1..64 (got 0)"-style messages naming the option.
  Request& set(const std::string& key, const std::string& text);
  Request& set(const std::string& key, double v);
  Request& setFlag(const std::string& key, bool v);
  /// Removes a given value (a scene-backed key goes back to the scene's value).
  void unset(const std::string& key);
  bool given(const std::string& key) const { return m_given.count(key) != 0; }
  bool has(const std::string& key) const { return m_values.has(key); }
  /// Throws when a required positional or option is missing.
  void validate() const;

  double f(const std::string& k) const { return m_values.f(k); }
  int i(const std::string& k) const { return m_values.i(k); }
  bool b(const std::string& k) const { return m_values.b(k); }
  const std::string& s(const std::string& k) const { return m_values.s(k); }
  /// The value as text (the CLI's form: numbers shortest round-trip, flags true/false).
  std::string text(const std::string& k) const;
  const ParamSet& values() const { return m_values; }
  /// {"command": …, "options": {key: value…}}: what `--json` reports echo.
  std::string toJson() const;

 private:
  const CommandDecl* m_decl;
  ParamSet m_values;
  std::set<std::string> m_given;
};

/// Markdown: one options table per command (the generated part of docs/cli.md).
std::string commandsMarkdown();
/// JSON Schema of one command's request (its options, types, ranges, defaults).
std::string requestSchema(const std::string& command);

}  // namespace btf::ops
