#pragma once
// Readers of just enough of the PNG and GIF formats to check that the viewers' files are
// whole: the PNG's size from its header, the GIF's block structure walked to the trailer and
// its frames counted.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

namespace wj::viz::testing {

inline std::vector<unsigned char> readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct ImageInfo {
  int width = 0, height = 0;
  int frames = 0;  ///< GIF: image descriptors; PNG: 1
};

/// Throws std::runtime_error when the bytes are not a PNG with an IHDR chunk and an IEND.
inline ImageInfo readPngInfo(const std::vector<unsigned char>& b) {
  const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (b.size() < 33 || !std::equal(sig, sig + 8, b.begin())) throw std::runtime_error("not a PNG");
  const auto be32 = [&](std::size_t at) {
    return static_cast<int>((b[at] << 24) | (b[at + 1] << 16) | (b[at + 2] << 8) | b[at + 3]);
  };
  if (std::string(b.begin() + 12, b.begin() + 16) != "IHDR") throw std::runtime_error("no IHDR");
  // Walk the chunks to IEND: a truncated file fails here.
  std::size_t at = 8;
  bool end = false;
  while (at + 12 <= b.size()) {
    const std::size_t len = static_cast<std::size_t>(be32(at));
    const std::string type(b.begin() + static_cast<long>(at) + 4,
                           b.begin() + static_cast<long>(at) + 8);
    at += 12 + len;
    if (type == "IEND") {
      end = true;
      break;
    }
  }
  if (!end || at != b.size()) throw std::runtime_error("PNG chunks do not end with IEND");
  return {be32(16), be32(20), 1};
}

/// Throws std::runtime_error when the bytes are not a GIF whose blocks end with the trailer.
inline ImageInfo readGifInfo(const std::vector<unsigned char>& b) {
  if (b.size() < 14 || std::string(b.begin(), b.begin() + 6) != "GIF89a")
    throw std::runtime_error("not a GIF89a");
  ImageInfo info;
  info.width = b[6] | (b[7] << 8);
  info.height = b[8] | (b[9] << 8);
  std::size_t at = 13;
  if (b[10] & 0x80) at += 3u << ((b[10] & 7) + 1);  // global colour table
  const auto skipSubBlocks = [&] {
    while (at < b.size() && b[at] != 0) at += 1 + b[at];
    ++at;
  };
  while (at < b.size()) {
    const unsigned char kind = b[at];
    if (kind == 0x3b) return info;  // trailer
    if (kind == 0x21) {             // extension: label, sub-blocks
      at += 2;
      skipSubBlocks();
    } else if (kind == 0x2c) {  // image: descriptor, local colour table, LZW size, data
      if (at + 10 > b.size()) break;
      const unsigned char flags = b[at + 9];
      at += 10;
      if (flags & 0x80) at += 3u << ((flags & 7) + 1);
      at += 1;
      skipSubBlocks();
      ++info.frames;
    } else {
      throw std::runtime_error("GIF: unknown block " + std::to_string(kind));
    }
  }
  throw std::runtime_error("GIF: no trailer (truncated)");
}

}  // namespace wj::viz::testing
