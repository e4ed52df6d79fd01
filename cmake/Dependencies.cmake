# Every third-party dependency, found once. Versions are Debian 12's; see
# ../shared/notes/platform-debian12.md for why some come through pkg-config.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)

find_package(OpenEXR 3 CONFIG REQUIRED)
find_package(Imath CONFIG REQUIRED)
find_package(PNG REQUIRED)
find_package(nlohmann_json 3 CONFIG REQUIRED)
find_package(fmt CONFIG REQUIRED)
find_package(spdlog CONFIG REQUIRED)
find_package(CLI11 CONFIG REQUIRED)
find_package(hwy CONFIG REQUIRED)

find_package(ZLIB REQUIRED)
# ISA-L's igzip deflates PNG image data several times faster than zlib at the same ratio,
# with the sync flushes that let each thread compress its own segment of one zlib stream
# (encode/io/zlib_stream.hpp; measured in docs/performance.md "Frame I/O").
pkg_check_modules(ISAL REQUIRED IMPORTED_TARGET libisal)
# xxHash's XXH3 digests uploads for the daemon's coalescing key (encode/io/digest.hpp): an
# order of magnitude faster than a byte-wise hash, on the request's critical path.
pkg_check_modules(XXHASH REQUIRED IMPORTED_TARGET libxxhash)

# Debian's OpenColorIOConfig.cmake computes a broken prefix: use pkg-config.
pkg_check_modules(OCIO REQUIRED IMPORTED_TARGET OpenColorIO)

# GL stack: EGL through glvnd, OSMesa as a fallback. GL entry points are loaded
# through each context's own get-proc-address, so no libGL/libOpenGL link is needed.
pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
pkg_check_modules(OSMESA REQUIRED IMPORTED_TARGET osmesa)
pkg_check_modules(LIBDRM REQUIRED IMPORTED_TARGET libdrm)
find_package(TinyGLTF CONFIG REQUIRED)

# Shareable HDR stills (encode/io/stills.hpp): libavif 0.11 (with libaom) for AVIF, libjxl 0.7
# for JPEG XL, libjpeg-turbo for the SDR and gain-map JPEGs. Debian's CMake configs for these
# are missing or partial; their .pc files are complete.
pkg_check_modules(AVIF REQUIRED IMPORTED_TARGET libavif>=0.11)
pkg_check_modules(JXL REQUIRED IMPORTED_TARGET libjxl>=0.7 libjxl_threads>=0.7)
pkg_check_modules(JPEG REQUIRED IMPORTED_TARGET libjpeg)

pkg_check_modules(MHD REQUIRED IMPORTED_TARGET libmicrohttpd)

# Video (encode/video): FFmpeg 5.1's libraries with Debian's x265, SVT-AV1, libaom, x264.
pkg_check_modules(LIBAV REQUIRED IMPORTED_TARGET libavcodec libavformat libavutil)
find_package(tomlplusplus CONFIG REQUIRED)

if(HDRD_BUILD_TESTS)
  find_package(GTest CONFIG REQUIRED)
endif()
if(HDRD_BUILD_BENCH)
  find_package(benchmark CONFIG REQUIRED)
endif()
