#include "display/kms.hpp"

#include <time.h>

#include <fmt/format.h>

namespace hdrd::display::kms {

std::int64_t KmsDevice::now_ns() const {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return std::int64_t(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

double ModeInfo::refresh_hz() const {
  const double total = double(htotal) * double(vtotal);
  return total > 0 ? clock_khz * 1000.0 / total : double(vrefresh);
}

std::optional<std::uint64_t> Property::enum_value(std::string_view entry) const {
  for (const auto& [n, v] : enums)
    if (n == entry) return v;
  return std::nullopt;
}

const Property* find_property(const Properties& props, std::string_view name) {
  for (const auto& p : props)
    if (p.name == name) return &p;
  return nullptr;
}

std::string_view to_string(ConnectionStatus s) {
  switch (s) {
    case ConnectionStatus::connected: return "connected";
    case ConnectionStatus::disconnected: return "disconnected";
    case ConnectionStatus::unknown: return "unknown";
  }
  return "unknown";
}

void AtomicRequest::fail(std::string message) {
  if (error_.empty()) error_ = std::move(message);
}

void AtomicRequest::add(std::uint32_t object, const Properties& props, std::string_view name, std::uint64_t value) {
  if (failed()) return;
  const Property* p = find_property(props, name);
  if (!p) {
    fail(fmt::format("object {} has no \"{}\" property", object, name));
    return;
  }
  items_.push_back({object, p->id, value, std::string(name)});
}

void AtomicRequest::add_enum(std::uint32_t object, const Properties& props, std::string_view name,
                             std::string_view entry) {
  if (failed()) return;
  const Property* p = find_property(props, name);
  if (!p) {
    fail(fmt::format("object {} has no \"{}\" property", object, name));
    return;
  }
  const auto v = p->enum_value(entry);
  if (!v) {
    std::vector<std::string> names;
    for (const auto& e : p->enums) names.push_back(e.first);
    fail(fmt::format("\"{}\" of object {} has no entry \"{}\" (it has: {})", name, object, entry,
                     fmt::join(names, ", ")));
    return;
  }
  items_.push_back({object, p->id, *v, std::string(name)});
}

bool AtomicRequest::add_if_present(std::uint32_t object, const Properties& props, std::string_view name,
                                   std::uint64_t value) {
  if (failed() || !find_property(props, name)) return false;
  add(object, props, name, value);
  return true;
}

std::optional<std::uint64_t> AtomicRequest::value_of(std::uint32_t object, std::string_view name) const {
  for (const auto& i : items_)
    if (i.object == object && i.name == name) return i.value;
  return std::nullopt;
}

}  // namespace hdrd::display::kms
