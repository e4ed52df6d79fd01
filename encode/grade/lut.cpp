// .cube reading and writing, and the reference (one colour at a time) evaluation.
// Format: Adobe "Cube LUT Specification 1.0" (2013) — TITLE, LUT_1D_SIZE / LUT_3D_SIZE,
// DOMAIN_MIN / DOMAIN_MAX, '#' comments, red-fastest data — plus Resolve's
// LUT_1D_INPUT_RANGE / LUT_3D_INPUT_RANGE and files holding a 1D shaper and a 3D table.
#include "encode/grade/lut.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cctype>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>

namespace hdrd::lut {

std::string_view to_string(Interpolation i) {
  return i == Interpolation::tetrahedral ? "tetrahedral" : "trilinear";
}

Lut1D Lut1D::identity(int size) {
  Lut1D l;
  l.size = size;
  l.rgb.resize(static_cast<std::size_t>(size) * 3);
  for (int i = 0; i < size; ++i)
    for (int c = 0; c < 3; ++c) l.rgb[i * 3 + c] = static_cast<float>(double(i) / (size - 1));
  return l;
}

Lut3D Lut3D::identity(int size) {
  Lut3D l;
  l.size = size;
  l.rgb.resize(static_cast<std::size_t>(size) * size * size * 3);
  for (int b = 0; b < size; ++b)
    for (int g = 0; g < size; ++g)
      for (int r = 0; r < size; ++r) {
        float* e = &l.rgb[l.index(r, g, b)];
        e[0] = static_cast<float>(double(r) / (size - 1));
        e[1] = static_cast<float>(double(g) / (size - 1));
        e[2] = static_cast<float>(double(b) / (size - 1));
      }
  return l;
}

// ---- Parsing --------------------------------------------------------------------------
namespace {

std::string_view trim(std::string_view s) {
  const auto not_space = [](char c) { return c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v'; };
  while (!s.empty() && !not_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && !not_space(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t') ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
  return out;
}

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

// Whole token as a float (a leading '+' is allowed; hex and trailing junk are not).
// Overflow gives infinity (reported as non-finite), underflow gives 0.
std::optional<float> to_float(std::string_view t) {
  const bool plus = !t.empty() && t.front() == '+';
  if (plus) t.remove_prefix(1);
  if (t.empty() || (plus && (t.front() == '+' || t.front() == '-'))) return std::nullopt;
  float v = 0;
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v, std::chars_format::general);
  if (p != t.data() + t.size()) return std::nullopt;
  if (ec == std::errc::result_out_of_range) {
    double d = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), d, std::chars_format::general);
    const bool huge = r.ec == std::errc() ? std::fabs(d) > 1.0 : t.find("e-") == std::string_view::npos &&
                                                                      t.find("E-") == std::string_view::npos;
    const float sign = t.front() == '-' ? -1.0f : 1.0f;
    return huge ? sign * std::numeric_limits<float>::infinity() : sign * 0.0f;
  }
  if (ec != std::errc()) return std::nullopt;
  return v;
}

std::optional<int> to_int(std::string_view t) {
  int v = 0;
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc() || p != t.data() + t.size()) return std::nullopt;
  return v;
}

std::string shorten(std::string_view s) {
  return s.size() > 40 ? std::string(s.substr(0, 40)) + "..." : std::string(s);
}

class CubeParser {
 public:
  explicit CubeParser(std::string_view name) : name_(name) {}

  Result<CubeFile> run(std::string_view text) {
    std::size_t pos = 0;
    while (pos < text.size() && !failed_) {
      const std::size_t nl = text.find('\n', pos);
      const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
      ++line_;
      line(text.substr(pos, end - pos));
      if (nl == std::string_view::npos) break;
      pos = nl + 1;
    }
    if (failed_) return error_;
    return finish(text.size());
  }

 private:
  Error fail(std::string code, std::string what) {
    failed_ = true;
    error_ = make_error(std::move(code), fmt::format("{}:{}: {}", name_, line_, what), "lut");
    return error_;
  }

  void line(std::string_view raw) {
    if (raw.find('\0') != std::string_view::npos) {
      fail("cube.syntax", "NUL byte: not a text .cube file");
      return;
    }
    const std::string_view s = trim(raw);
    if (s.empty()) return;
    if (s.front() == '#') {
      if (!data_started_) {
        std::string_view c = s.substr(1);
        if (!c.empty() && c.front() == ' ') c.remove_prefix(1);
        cube_.comments.emplace_back(c);
      }
      return;
    }
    const char c0 = s.front();
    if (std::isalpha(static_cast<unsigned char>(c0)) && !is_number_word(s)) {
      keyword(s);
    } else {
      data(s);
    }
  }

  static bool is_number_word(std::string_view s) {
    const std::string u = upper(s.substr(0, 3));
    return u == "NAN" || u == "INF";
  }

  void keyword(std::string_view s) {
    const auto tokens = split_ws(s);
    const std::string key = upper(tokens[0]);
    if (data_started_) {
      fail("cube.syntax", fmt::format("keyword {} after the table data (keywords come first)", key));
      return;
    }
    if (!seen_.insert(key).second) {
      fail("cube.syntax", fmt::format("{} given twice", key));
      return;
    }
    if (key == "TITLE") return title(s.substr(tokens[0].size()));
    if (key == "LUT_1D_SIZE") return size(tokens, size1d_, kMin1DSize, kMax1DSize);
    if (key == "LUT_3D_SIZE") return size(tokens, size3d_, kMin3DSize, kMax3DSize);
    if (key == "DOMAIN_MIN") return triple(tokens, domain_min_, domain_line_);
    if (key == "DOMAIN_MAX") return triple(tokens, domain_max_, domain_line_);
    if (key == "LUT_1D_INPUT_RANGE") return range(tokens, range1d_, range1d_line_);
    if (key == "LUT_3D_INPUT_RANGE") return range(tokens, range3d_, range3d_line_);
    if (key == "LUT_2D_SIZE") {
      fail("cube.syntax", "LUT_2D_SIZE is not supported (only 1D and 3D tables)");
      return;
    }
    fail("cube.syntax", fmt::format("unknown keyword '{}'", shorten(tokens[0])));
  }

  void title(std::string_view rest) {
    rest = trim(rest);
    if (rest.size() < 2 || rest.front() != '"' || rest.back() != '"' ||
        rest.substr(1, rest.size() - 2).find('"') != std::string_view::npos) {
      fail("cube.syntax", "TITLE needs one double-quoted string, e.g. TITLE \"My look\"");
      return;
    }
    cube_.title = std::string(rest.substr(1, rest.size() - 2));
  }

  void size(const std::vector<std::string_view>& t, int& out, int lo, int hi) {
    const std::string key = upper(t[0]);
    if (t.size() != 2) {
      fail("cube.syntax", fmt::format("{} takes one integer", key));
      return;
    }
    const auto v = to_int(t[1]);
    if (!v) {
      fail("cube.syntax", fmt::format("{} '{}' is not an integer", key, shorten(t[1])));
      return;
    }
    if (*v < lo || *v > hi) {
      fail("cube.size", fmt::format("{} {} is outside {}..{}", key, *v, lo, hi));
      return;
    }
    out = *v;
  }

  void triple(const std::vector<std::string_view>& t, std::optional<Rgb>& out, int& where) {
    const std::string key = upper(t[0]);
    Rgb v{};
    if (t.size() != 4) {
      fail("cube.syntax", fmt::format("{} takes three numbers, got {}", key, t.size() - 1));
      return;
    }
    for (int c = 0; c < 3; ++c) {
      const auto f = to_float(t[c + 1]);
      if (!f || !std::isfinite(*f)) {
        fail("cube.syntax", fmt::format("{}: '{}' is not a finite number", key, shorten(t[c + 1])));
        return;
      }
      v[c] = *f;
    }
    out = v;
    where = line_;
  }

  void range(const std::vector<std::string_view>& t, std::optional<std::array<float, 2>>& out, int& where) {
    const std::string key = upper(t[0]);
    if (t.size() != 3) {
      fail("cube.syntax", fmt::format("{} takes two numbers (min max), got {}", key, t.size() - 1));
      return;
    }
    std::array<float, 2> v{};
    for (int i = 0; i < 2; ++i) {
      const auto f = to_float(t[i + 1]);
      if (!f || !std::isfinite(*f)) {
        fail("cube.syntax", fmt::format("{}: '{}' is not a finite number", key, shorten(t[i + 1])));
        return;
      }
      v[i] = *f;
    }
    if (!(v[0] < v[1])) {
      fail("cube.domain", fmt::format("{} min {} must be below max {}", key, v[0], v[1]));
      return;
    }
    out = v;
    where = line_;
  }

  bool start_data() {
    if (size1d_ == 0 && size3d_ == 0) {
      fail("cube.syntax", "table data before LUT_1D_SIZE or LUT_3D_SIZE");
      return false;
    }
    if (!check_domains()) return false;
    data_started_ = true;
    set_expected();
    return true;
  }

  void set_expected() {
    expected1d_ = static_cast<std::size_t>(size1d_);
    expected3d_ = static_cast<std::size_t>(size3d_) * size3d_ * size3d_;
  }

  bool check_domains() {
    const bool both = size1d_ > 0 && size3d_ > 0;
    if ((domain_min_ || domain_max_) && both) {
      line_ = domain_line_;
      fail("cube.syntax", "DOMAIN_MIN/DOMAIN_MAX is ambiguous with both LUT_1D_SIZE and LUT_3D_SIZE; "
                          "use LUT_1D_INPUT_RANGE / LUT_3D_INPUT_RANGE");
      return false;
    }
    if ((range1d_ && size1d_ == 0) || (range3d_ && size3d_ == 0)) {
      line_ = range1d_ && size1d_ == 0 ? range1d_line_ : range3d_line_;
      fail("cube.syntax", "LUT_xD_INPUT_RANGE given for a table the file does not declare");
      return false;
    }
    Domain d;
    if (domain_min_) d.min = *domain_min_;
    if (domain_max_) d.max = *domain_max_;
    for (int c = 0; c < 3; ++c)
      if (!(d.min[c] < d.max[c])) {
        line_ = domain_line_;
        fail("cube.domain", fmt::format("DOMAIN_MIN {} must be below DOMAIN_MAX {} in channel {}",
                                        d.min[c], d.max[c], "RGB"[c]));
        return false;
      }
    const auto from_range = [](const std::optional<std::array<float, 2>>& r, const Domain& fallback) {
      if (!r) return fallback;
      Domain out;
      out.min = {(*r)[0], (*r)[0], (*r)[0]};
      out.max = {(*r)[1], (*r)[1], (*r)[1]};
      return out;
    };
    domain1d_ = from_range(range1d_, d);
    domain3d_ = from_range(range3d_, d);
    return true;
  }

  void data(std::string_view s) {
    if (!data_started_ && !start_data()) return;
    const auto t = split_ws(s);
    if (t.size() != 3) {
      fail("cube.syntax", fmt::format("expected 3 numbers (R G B), got {}: '{}'", t.size(), shorten(s)));
      return;
    }
    Rgb v{};
    for (int c = 0; c < 3; ++c) {
      const auto f = to_float(t[c]);
      if (!f) {
        fail("cube.syntax", fmt::format("'{}' is not a number", shorten(t[c])));
        return;
      }
      if (!std::isfinite(*f)) {
        fail("cube.value", fmt::format("'{}' is not finite", shorten(t[c])));
        return;
      }
      v[c] = *f;
    }
    std::vector<float>& dst = entries1d_.size() / 3 < expected1d_ ? entries1d_ : entries3d_;
    if (&dst == &entries3d_ && entries3d_.size() / 3 >= expected3d_) {
      fail("cube.size", fmt::format("more entries than declared ({} expected)", expected1d_ + expected3d_));
      return;
    }
    if (dst.empty()) dst.reserve(std::min<std::size_t>(3 * (&dst == &entries1d_ ? expected1d_ : expected3d_), 3 * 65536));
    dst.insert(dst.end(), v.begin(), v.end());
  }

  Result<CubeFile> finish(std::size_t) {
    line_ = std::max(line_, 1);
    if (!data_started_) {
      if (size1d_ == 0 && size3d_ == 0) {
        fail("cube.syntax", "no LUT_1D_SIZE or LUT_3D_SIZE: not a .cube file");
        return error_;
      }
      if (!check_domains()) return error_;
      set_expected();  // a header without data: the count check below reports it
    }
    const std::size_t got = (entries1d_.size() + entries3d_.size()) / 3;
    if (got != expected1d_ + expected3d_) {
      fail("cube.size", fmt::format("file ends after {} entries; LUT_{}_SIZE declares {}", got,
                                    size3d_ > 0 ? "3D" : "1D", expected1d_ + expected3d_));
      return error_;
    }
    if (size1d_ > 0) cube_.lut1d = Lut1D{size1d_, std::move(entries1d_), domain1d_};
    if (size3d_ > 0) cube_.lut3d = Lut3D{size3d_, std::move(entries3d_), domain3d_};
    return std::move(cube_);
  }

  std::string name_;
  int line_ = 0;
  bool failed_ = false;
  Error error_;
  CubeFile cube_;
  std::set<std::string> seen_;
  int size1d_ = 0, size3d_ = 0;
  std::optional<Rgb> domain_min_, domain_max_;
  std::optional<std::array<float, 2>> range1d_, range3d_;
  int domain_line_ = 0, range1d_line_ = 0, range3d_line_ = 0;
  Domain domain1d_, domain3d_;
  bool data_started_ = false;
  std::size_t expected1d_ = 0, expected3d_ = 0;
  std::vector<float> entries1d_, entries3d_;
};

}  // namespace

Result<CubeFile> parse_cube(std::string_view text, std::string_view name) {
  // A UTF-8 byte-order mark is harmless; editors add it.
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  return CubeParser(name).run(text);
}

Result<CubeFile> read_cube(const std::filesystem::path& path, const io::InputFiles& files) {
  // 256^3 entries at ~40 bytes a line, with room for comments.
  auto text = files.read(path, std::size_t(1) << 30);
  if (!text && text.error().code == "file.too_large")
    return make_error("cube.size", fmt::format("{}: too large for a .cube (over 1 GiB)", path.string()), "lut");
  if (!text) return io::reader_error(text.error(), "cube.io", "cube.io", "lut");
  return parse_cube(*text, path.string());
}

// ---- Writing --------------------------------------------------------------------------
namespace {

Result<void> check_table(int size, std::size_t entries, std::size_t want, int lo, int hi, const char* what) {
  if (size < lo || size > hi)
    return make_error("cube.size", fmt::format("{} size {} is outside {}..{}", what, size, lo, hi));
  if (entries != want)
    return make_error("cube.size", fmt::format("{} has {} values, size {} needs {}", what, entries, size, want));
  return {};
}

void append_entries(std::string& out, const std::vector<float>& v) {
  for (std::size_t i = 0; i + 2 < v.size(); i += 3) fmt::format_to(std::back_inserter(out), "{} {} {}\n", v[i], v[i + 1], v[i + 2]);
}

}  // namespace

Result<std::string> format_cube(const CubeFile& cube) {
  if (!cube.lut1d && !cube.lut3d) return make_error("cube.size", "nothing to write: no 1D or 3D table");
  if (cube.title.find_first_of("\"\n\r") != std::string::npos)
    return make_error("cube.syntax", "TITLE cannot contain quotes or line breaks");
  const bool both = cube.lut1d && cube.lut3d;
  std::string out;
  for (const auto& c : cube.comments) {
    if (c.find_first_of("\n\r") != std::string::npos) return make_error("cube.syntax", "a comment cannot contain line breaks");
    out += c.empty() ? "#\n" : "# " + c + "\n";
  }
  if (!cube.title.empty()) out += fmt::format("TITLE \"{}\"\n", cube.title);
  const auto header = [&](const auto& lut, const char* kind, std::size_t want, int lo, int hi) -> Result<void> {
    auto ok = check_table(lut.size, lut.rgb.size(), want, lo, hi, kind);
    if (!ok) return ok;
    for (float v : lut.rgb)
      if (!std::isfinite(v)) return make_error("cube.value", fmt::format("{} holds a non-finite value", kind));
    out += fmt::format("LUT_{}_SIZE {}\n", kind, lut.size);
    if (lut.domain.is_unit()) return {};
    if (both) {
      if (!lut.domain.is_uniform())
        return make_error("cube.domain", fmt::format("a {} shaper + 3D file needs the same domain in R, G and B", kind));
      out += fmt::format("LUT_{}_INPUT_RANGE {} {}\n", kind, lut.domain.min[0], lut.domain.max[0]);
    } else {
      const auto& d = lut.domain;
      out += fmt::format("DOMAIN_MIN {} {} {}\nDOMAIN_MAX {} {} {}\n", d.min[0], d.min[1], d.min[2], d.max[0], d.max[1], d.max[2]);
    }
    return {};
  };
  if (cube.lut1d) {
    auto ok = header(*cube.lut1d, "1D", std::size_t(cube.lut1d->size) * 3, kMin1DSize, kMax1DSize);
    if (!ok) return ok.error();
  }
  if (cube.lut3d) {
    const std::size_t n = static_cast<std::size_t>(cube.lut3d->size);
    auto ok = header(*cube.lut3d, "3D", n * n * n * 3, kMin3DSize, kMax3DSize);
    if (!ok) return ok.error();
  }
  if (cube.lut1d) append_entries(out, cube.lut1d->rgb);
  if (cube.lut3d) append_entries(out, cube.lut3d->rgb);
  return out;
}

Result<void> write_cube(const CubeFile& cube, const std::filesystem::path& path) {
  auto text = format_cube(cube);
  if (!text) return text.error();
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) return make_error("cube.io", fmt::format("{}: cannot write", path.string()), "output");
  f.write(text->data(), static_cast<std::streamsize>(text->size()));
  if (!f) return make_error("cube.io", fmt::format("{}: write failed", path.string()), "output");
  return {};
}

// ---- Reference evaluation -------------------------------------------------------------
namespace {

// Lattice coordinate of x in [0, n-1] (OCIO Lut3DOp: domain scale, then clamp; NaN -> 0).
float lattice(float x, float dmin, float dmax, int n) {
  const float t = (x - dmin) * (float(n - 1) / (dmax - dmin));
  return t > 0 ? std::min(t, float(n - 1)) : 0.0f;
}

}  // namespace

Rgb eval(const Lut1D& lut, Rgb in) {
  Rgb out{};
  for (int c = 0; c < 3; ++c) {
    const float t = lattice(in[c], lut.domain.min[c], lut.domain.max[c], lut.size);
    const int i0 = std::min(static_cast<int>(t), lut.size - 2);
    const float f = t - float(i0);
    const float a = lut.rgb[i0 * 3 + c], b = lut.rgb[(i0 + 1) * 3 + c];
    out[c] = a + (b - a) * f;
  }
  return out;
}

Rgb eval(const Lut3D& lut, Rgb in, Interpolation interp) {
  const int n = lut.size;
  int i[3];
  float f[3];
  for (int c = 0; c < 3; ++c) {
    const float t = lattice(in[c], lut.domain.min[c], lut.domain.max[c], n);
    i[c] = std::min(static_cast<int>(t), n - 2);
    f[c] = t - float(i[c]);
  }
  const auto at = [&](int dr, int dg, int db, int c) { return lut.rgb[lut.index(i[0] + dr, i[1] + dg, i[2] + db) + c]; };
  Rgb out{};
  if (interp == Interpolation::trilinear) {
    for (int c = 0; c < 3; ++c) {
      const float c00 = at(0, 0, 0, c) + (at(1, 0, 0, c) - at(0, 0, 0, c)) * f[0];
      const float c10 = at(0, 1, 0, c) + (at(1, 1, 0, c) - at(0, 1, 0, c)) * f[0];
      const float c01 = at(0, 0, 1, c) + (at(1, 0, 1, c) - at(0, 0, 1, c)) * f[0];
      const float c11 = at(0, 1, 1, c) + (at(1, 1, 1, c) - at(0, 1, 1, c)) * f[0];
      const float c0 = c00 + (c10 - c00) * f[1];
      const float c1 = c01 + (c11 - c01) * f[1];
      out[c] = c0 + (c1 - c0) * f[2];
    }
    return out;
  }
  // Tetrahedral (Kasson et al. 1995; OCIO Lut3DOpCPU): the cube splits into six
  // tetrahedra along its diagonal; the ordering of the fractions picks one.
  const float fr = f[0], fg = f[1], fb = f[2];
  for (int c = 0; c < 3; ++c) {
    const float n000 = at(0, 0, 0, c), n111 = at(1, 1, 1, c);
    float v;
    if (fr > fg) {
      if (fg > fb) v = (1 - fr) * n000 + (fr - fg) * at(1, 0, 0, c) + (fg - fb) * at(1, 1, 0, c) + fb * n111;
      else if (fr > fb) v = (1 - fr) * n000 + (fr - fb) * at(1, 0, 0, c) + (fb - fg) * at(1, 0, 1, c) + fg * n111;
      else v = (1 - fb) * n000 + (fb - fr) * at(0, 0, 1, c) + (fr - fg) * at(1, 0, 1, c) + fg * n111;
    } else {
      if (fb > fg) v = (1 - fb) * n000 + (fb - fg) * at(0, 0, 1, c) + (fg - fr) * at(0, 1, 1, c) + fr * n111;
      else if (fb > fr) v = (1 - fg) * n000 + (fg - fb) * at(0, 1, 0, c) + (fb - fr) * at(0, 1, 1, c) + fr * n111;
      else v = (1 - fg) * n000 + (fg - fr) * at(0, 1, 0, c) + (fr - fb) * at(1, 1, 0, c) + fb * n111;
    }
    out[c] = v;
  }
  return out;
}

Rgb eval(const CubeFile& cube, Rgb in, Interpolation interp) {
  if (cube.lut1d) in = eval(*cube.lut1d, in);
  if (cube.lut3d) in = eval(*cube.lut3d, in, interp);
  return in;
}

}  // namespace hdrd::lut
