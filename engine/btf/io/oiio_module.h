// The C interface of the OpenImageIO module (engine/oiio, built as libbtf_oiio.so), which the
// engine loads on its first image read or write (image_io.cpp). OpenImageIO on Debian 12 brings
// ~260 shared libraries (OpenCV, FFmpeg, GDAL, OpenVDB, DCMTK, …) whose loading costs ~0.35 s
// of every process start on the 2-core machine: a command that touches no image pays nothing.
// Plain C types only (no exception or std:: type crosses it); errors are one line in `err`.
#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {

/// Bumped whenever a signature or struct below changes: the loader refuses another module.
#define BTF_OIIO_ABI 1

struct BtfOiioWrite {
  const char* path;   ///< the name whose extension picks the writer
  const char* tmp;    ///< the file actually written (renamed by the caller)
  int width, height, channels;
  int hdr;            ///< 1: EXR, linear float; 0: 8-bit sRGB (PNG, or JPEG at quality 95)
  int jpeg;           ///< with hdr 0: JPEG rather than PNG
  const char* const* metaKeys;  ///< EXR attributes "btf:KEY" = VALUE
  const char* const* metaValues;
  int metaCount;
  const float* pixels;  ///< width × height × channels, top row first
};

struct BtfOiioSpec {
  int64_t width, height, channels, depth;
};

typedef int (*BtfOiioAbiFn)(void);
/// 0 on success; otherwise err holds OpenImageIO's reason.
typedef int (*BtfOiioWriteFn)(const BtfOiioWrite* w, char* err, size_t errSize);
/// Opens `path` with the named plugin alone; a handle, or null with err set.
typedef void* (*BtfOiioOpenFn)(const char* plugin, const char* path, BtfOiioSpec* spec, char* err,
                               size_t errSize);
/// Reads the first `channels` channels of the whole image as float; 0 on success.
typedef int (*BtfOiioReadFn)(void* handle, int channels, float* out, char* err, size_t errSize);
typedef void (*BtfOiioCloseFn)(void* handle);
}
