// Machine facts the planner and reports need: memory in use, free disk, byte-size parsing.
#pragma once
#include <cstdint>
#include <string>

namespace btf {

/// Peak resident set size of this process in bytes (VmHWM), 0 when unknown.
uint64_t peakRssBytes();
/// Current resident set size in bytes (VmRSS), 0 when unknown.
uint64_t currentRssBytes();
/// Free bytes on the file system holding `path` (or its parent folder), 0 when unknown.
uint64_t freeDiskBytes(const std::string& path);
/// "4G", "512M", "1.5GiB", "1000" (bytes) → bytes. Throws btf::Error with the text on failure.
uint64_t parseBytes(const std::string& text);
/// 1536 → "1.5 KiB".
std::string formatBytes(double bytes);
/// 75.2 → "1 min 15 s".
std::string formatSeconds(double seconds);

}  // namespace btf
