// content_digest is XXH3-128: checked against xxHash's published vectors (the empty input
// from its sanity tests, "abc" as `xxhsum -H2` prints it), not against its own output.
#include <gtest/gtest.h>

#include <string>

#include "encode/io/digest.hpp"

namespace {

TEST(ContentDigest, PublishedXxh3_128Vectors) {
  EXPECT_EQ(hdrd::io::content_digest(""), "99aa06d3014798d86001c324468d497f");
  EXPECT_EQ(hdrd::io::content_digest("abc"), "06b05ab6733a618578af5f94892f3950");
}

TEST(ContentDigest, OneByteAnywhereChangesIt) {
  std::string a(1 << 20, 'x');
  const std::string base = hdrd::io::content_digest(a);
  EXPECT_EQ(base.size(), 32u);
  for (std::size_t at : {std::size_t(0), a.size() / 2, a.size() - 1}) {
    std::string b = a;
    b[at] = 'y';
    EXPECT_NE(hdrd::io::content_digest(b), base) << "byte " << at;
  }
  EXPECT_NE(hdrd::io::content_digest(a + '\0'), base);  // the length counts
}

}  // namespace
