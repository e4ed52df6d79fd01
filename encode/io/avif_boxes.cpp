// ISOBMFF surgery for AVIF item properties (ISO/IEC 14496-12 §4.2 boxes, §8.11.3 iloc;
// ISO/IEC 23008-12 §9.3 ipco/ipma). Every read is bounds-checked: the input is libavif's
// output, but the function is fuzzed as if it were anyone's.
#include "encode/io/avif_boxes.hpp"

#include <cstring>
#include <optional>
#include <string>

#include <fmt/format.h>

namespace hdrd::io::detail {
namespace {

using Bytes = std::vector<std::uint8_t>;

Error container_error(const std::string& what) {
  return make_error("avif.container", "cannot add clli/mdcv to the AVIF libavif wrote: " + what);
}

std::uint64_t read_be(std::span<const std::uint8_t> b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}
void write_be(Bytes& b, std::size_t at, std::uint64_t v, int n) {
  for (int i = n - 1; i >= 0; --i, v >>= 8) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v);
}
void append_be(Bytes& b, std::uint64_t v, int n) {
  b.resize(b.size() + static_cast<std::size_t>(n));
  write_be(b, b.size() - static_cast<std::size_t>(n), v, n);
}

struct Box {
  std::string type;
  std::size_t begin = 0, end = 0;  // whole box within its buffer
  std::size_t header = 8;          // bytes before the payload (12 for a FullBox's version+flags)
};

// The boxes in [begin, end) of `b`; nullopt on a size that does not fit or a 64-bit size.
std::optional<std::vector<Box>> children(std::span<const std::uint8_t> b, std::size_t begin, std::size_t end) {
  std::vector<Box> out;
  for (std::size_t at = begin; at < end;) {
    if (end - at < 8) return std::nullopt;
    std::uint64_t size = read_be(b, at, 4);
    if (size == 0) size = end - at;  // "to the end of the enclosing space"
    if (size < 8 || size > end - at) return std::nullopt;
    out.push_back({std::string(reinterpret_cast<const char*>(&b[at + 4]), 4), at, at + size, 8});
    at += size;
  }
  return out;
}

const Box* find(const std::vector<Box>& boxes, const char* type) {
  const Box* hit = nullptr;
  for (const Box& x : boxes)
    if (x.type == type) {
      if (hit) return nullptr;  // ambiguous: a second one
      hit = &x;
    }
  return hit;
}

std::optional<std::uint32_t> primary_item(std::span<const std::uint8_t> b, const Box& pitm) {
  if (pitm.end - pitm.begin < 14) return std::nullopt;
  const int version = b[pitm.begin + 8];
  if (version == 0) return static_cast<std::uint32_t>(read_be(b, pitm.begin + 12, 2));
  if (pitm.end - pitm.begin < 16) return std::nullopt;
  return static_cast<std::uint32_t>(read_be(b, pitm.begin + 12, 4));
}

// ipma with `count` more associations (indices first_index...) for `item`.
std::optional<Bytes> grown_ipma(std::span<const std::uint8_t> b, const Box& ipma, std::uint32_t item,
                                std::uint32_t first_index, std::uint32_t count) {
  const std::size_t len = ipma.end - ipma.begin;
  if (len < 16) return std::nullopt;
  const int version = b[ipma.begin + 8];
  const bool wide_index = (read_be(b, ipma.begin + 9, 3) & 1) != 0;
  const int id_bytes = version < 1 ? 2 : 4, assoc_bytes = wide_index ? 2 : 1;
  if (first_index + count - 1 >= (wide_index ? 0x8000u : 0x80u)) return std::nullopt;
  Bytes out(b.begin() + static_cast<long>(ipma.begin), b.begin() + static_cast<long>(ipma.begin + 16));
  const std::uint64_t entries = read_be(b, ipma.begin + 12, 4);
  std::size_t at = ipma.begin + 16;
  bool found = false;
  for (std::uint64_t e = 0; e < entries; ++e) {
    if (ipma.end - at < static_cast<std::size_t>(id_bytes) + 1) return std::nullopt;
    const auto id = static_cast<std::uint32_t>(read_be(b, at, id_bytes));
    const std::size_t n = b[at + static_cast<std::size_t>(id_bytes)];
    const std::size_t entry = static_cast<std::size_t>(id_bytes) + 1 + n * static_cast<std::size_t>(assoc_bytes);
    if (ipma.end - at < entry) return std::nullopt;
    out.insert(out.end(), b.begin() + static_cast<long>(at), b.begin() + static_cast<long>(at + entry));
    if (id == item) {
      if (found || n + count > 255) return std::nullopt;
      found = true;
      out[out.size() - entry + static_cast<std::size_t>(id_bytes)] = static_cast<std::uint8_t>(n + count);
      for (std::uint32_t i = 0; i < count; ++i) append_be(out, first_index + i, assoc_bytes);  // essential bit 0
    }
    at += entry;
  }
  if (!found || at != ipma.end) return std::nullopt;
  write_be(out, 0, out.size(), 4);
  return out;
}

// Moves every absolute iloc offset at or past `from` by `delta` bytes, in place in `iloc`
// (a copy of the box). Offsets inside [meta_begin, from) cannot be moved: an error.
std::optional<std::string> shift_iloc(Bytes& iloc, std::uint64_t meta_begin, std::uint64_t from, std::uint64_t delta) {
  std::span<const std::uint8_t> b(iloc);
  if (iloc.size() < 16) return "iloc is truncated";
  const int version = b[8];
  if (version > 2) return fmt::format("iloc version {} is unknown", version);
  const int offset_size = b[12] >> 4, length_size = b[12] & 15, base_size = b[13] >> 4;
  const int index_size = version >= 1 ? (b[13] & 15) : 0;
  for (int s : {offset_size, length_size, base_size, index_size})
    if (s != 0 && s != 4 && s != 8) return "iloc has a field size other than 0, 4 or 8";
  const int id_bytes = version < 2 ? 2 : 4;
  std::size_t at = 14;
  const auto need = [&](std::size_t n) { return iloc.size() - at >= n; };
  if (!need(static_cast<std::size_t>(id_bytes))) return "iloc is truncated";
  const std::uint64_t items = read_be(b, at, id_bytes);
  at += static_cast<std::size_t>(id_bytes);
  const auto move = [&](std::size_t field, int size, std::uint64_t base) -> std::optional<std::string> {
    const std::uint64_t value = size ? read_be(b, field, size) : 0;
    if (base + value < from) {
      if (base + value >= meta_begin) return "an iloc extent points into meta";
      return std::nullopt;  // before meta (never for libavif): stays
    }
    if (size == 0) return "an iloc extent past meta has no offset field to move";
    if (size == 4 && value + delta > 0xffffffffu) return "an iloc offset would overflow 32 bits";
    write_be(iloc, field, value + delta, size);
    return std::nullopt;
  };
  for (std::uint64_t i = 0; i < items; ++i) {
    const std::size_t fixed = static_cast<std::size_t>(id_bytes) + (version >= 1 ? 2 : 0) + 2;
    if (!need(fixed + static_cast<std::size_t>(base_size) + 2)) return "iloc is truncated";
    const int method = version >= 1 ? (read_be(b, at + static_cast<std::size_t>(id_bytes), 2) & 15) : 0;
    const std::uint64_t data_ref = read_be(b, at + fixed - 2, 2);
    at += fixed;
    const std::size_t base_field = at;
    at += static_cast<std::size_t>(base_size);
    const std::uint64_t extents = read_be(b, at, 2);
    at += 2;
    const bool absolute = method == 0 && data_ref == 0;  // file offsets (idat/item offsets stay)
    if (absolute && base_size) {
      if (auto err = move(base_field, base_size, 0)) return err;
    }
    for (std::uint64_t e = 0; e < extents; ++e) {
      const std::size_t extent = static_cast<std::size_t>(index_size + offset_size + length_size);
      if (!need(extent)) return "iloc is truncated";
      if (absolute && !base_size) {
        if (auto err = move(at + static_cast<std::size_t>(index_size), offset_size, 0)) return err;
      }
      at += extent;
    }
  }
  return std::nullopt;
}

}  // namespace

Bytes make_box(const char (&type)[5], std::span<const std::uint8_t> payload) {
  Bytes box;
  append_be(box, 8 + payload.size(), 4);
  box.insert(box.end(), type, type + 4);
  box.insert(box.end(), payload.begin(), payload.end());
  return box;
}

Result<Bytes> add_item_properties(std::span<const std::uint8_t> file, const std::vector<Bytes>& properties) {
  if (properties.empty()) return Bytes(file.begin(), file.end());
  const auto top = children(file, 0, file.size());
  if (!top) return container_error("a top-level box size does not fit the file");
  const Box* meta = find(*top, "meta");
  if (!meta) return container_error("no single meta box");
  const auto in_meta = children(file, meta->begin + 12, meta->end);
  if (!in_meta) return container_error("a box inside meta does not fit");
  const Box* iprp = find(*in_meta, "iprp");
  const Box* iloc = find(*in_meta, "iloc");
  const Box* pitm = find(*in_meta, "pitm");
  if (!iprp || !iloc || !pitm) return container_error("meta lacks one of iprp, iloc, pitm");
  const auto item = primary_item(file, *pitm);
  const auto in_iprp = children(file, iprp->begin + 8, iprp->end);
  if (!item || !in_iprp) return container_error("pitm or iprp is malformed");
  const Box* ipco = find(*in_iprp, "ipco");
  const Box* ipma = find(*in_iprp, "ipma");
  const auto props = ipco ? children(file, ipco->begin + 8, ipco->end) : std::nullopt;
  if (!ipma || !props) return container_error("iprp lacks ipco or ipma");

  Bytes new_ipco(file.begin() + static_cast<long>(ipco->begin), file.begin() + static_cast<long>(ipco->end));
  for (const Bytes& p : properties) new_ipco.insert(new_ipco.end(), p.begin(), p.end());
  write_be(new_ipco, 0, new_ipco.size(), 4);
  const auto first_index = static_cast<std::uint32_t>(props->size() + 1);  // ipma indices are 1-based
  const auto new_ipma = grown_ipma(file, *ipma, *item, first_index, static_cast<std::uint32_t>(properties.size()));
  if (!new_ipma) return container_error("ipma is malformed, lacks the primary item or has no room for more");

  Bytes new_iprp(file.begin() + static_cast<long>(iprp->begin), file.begin() + static_cast<long>(iprp->begin + 8));
  for (const Box& c : *in_iprp) {
    if (&c == ipco) new_iprp.insert(new_iprp.end(), new_ipco.begin(), new_ipco.end());
    else if (&c == ipma) new_iprp.insert(new_iprp.end(), new_ipma->begin(), new_ipma->end());
    else new_iprp.insert(new_iprp.end(), file.begin() + static_cast<long>(c.begin), file.begin() + static_cast<long>(c.end));
  }
  write_be(new_iprp, 0, new_iprp.size(), 4);
  const std::uint64_t delta = new_iprp.size() - (iprp->end - iprp->begin);

  Bytes new_meta(file.begin() + static_cast<long>(meta->begin), file.begin() + static_cast<long>(meta->begin + 12));
  for (const Box& c : *in_meta) {
    if (&c == iprp) {
      new_meta.insert(new_meta.end(), new_iprp.begin(), new_iprp.end());
      continue;
    }
    Bytes copy(file.begin() + static_cast<long>(c.begin), file.begin() + static_cast<long>(c.end));
    if (&c == iloc) {
      if (auto err = shift_iloc(copy, meta->begin, meta->end, delta)) return container_error(*err);
    }
    new_meta.insert(new_meta.end(), copy.begin(), copy.end());
  }
  if (new_meta.size() > 0xffffffffu) return container_error("meta would exceed 4 GiB");
  write_be(new_meta, 0, new_meta.size(), 4);

  Bytes out(file.begin(), file.begin() + static_cast<long>(meta->begin));
  out.insert(out.end(), new_meta.begin(), new_meta.end());
  out.insert(out.end(), file.begin() + static_cast<long>(meta->end), file.end());
  return out;
}

}  // namespace hdrd::io::detail
