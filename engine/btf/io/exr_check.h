// A checked pass over an OpenEXR file's headers before OpenEXR (through OpenImageIO) reads it.
// OpenEXR sizes its allocations from the header: an attribute's declared size, and the data
// window, which sizes the line-offset table — a flipped byte there is a multi-gigabyte
// allocation before a single pixel is read. This pass walks every attribute within the file's
// own bytes and bounds the data window by the caller's pixel limit.
#pragma once
#include <cstdint>
#include <string>

namespace btf {

/// Throws btf::Error "PATH: malformed OpenEXR header: …" (naming the attribute and the rule)
/// when an attribute runs past the end of the file, a name is too long, the header has no
/// dataWindow, or a part's data window is empty or larger than `maxPixels` pixels (or 65536 on
/// a side). `bytes` is the file's content.
void checkExrHeader(const std::string& path, const std::string& bytes, uint64_t maxPixels);

}  // namespace btf
