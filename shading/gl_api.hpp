// A per-context GL function table. Every GL call in hdrd goes through one of these,
// filled from the context's own get-proc-address (eglGetProcAddress or
// OSMesaGetProcAddress): libOSMesa and glvnd both export `gl*` symbols, and a direct
// call binds to whichever the linker saw first (platform-debian12.md §2).
#pragma once

#include <GL/glcorearb.h>  // types and enums only; no prototypes without GL_GLEXT_PROTOTYPES

#include <string>

// X(name-without-gl-prefix, PFN type). Only what hdrd uses; everything exists in both
// desktop GL 4.5 core and GLES 3.2 unless noted in `kDesktopOnly` below.
#define HDRD_GL_FUNCTIONS(X)                                            \
  X(GetError, PFNGLGETERRORPROC)                                        \
  X(GetString, PFNGLGETSTRINGPROC)                                      \
  X(GetStringi, PFNGLGETSTRINGIPROC)                                    \
  X(GetIntegerv, PFNGLGETINTEGERVPROC)                                  \
  X(GetInternalformativ, PFNGLGETINTERNALFORMATIVPROC)                  \
  X(Enable, PFNGLENABLEPROC)                                            \
  X(Disable, PFNGLDISABLEPROC)                                          \
  X(Viewport, PFNGLVIEWPORTPROC)                                        \
  X(ClearBufferfv, PFNGLCLEARBUFFERFVPROC)                              \
  X(ClearBufferfi, PFNGLCLEARBUFFERFIPROC)                              \
  X(ClearBufferuiv, PFNGLCLEARBUFFERUIVPROC)                            \
  X(DepthFunc, PFNGLDEPTHFUNCPROC)                                      \
  X(DepthMask, PFNGLDEPTHMASKPROC)                                      \
  X(CullFace, PFNGLCULLFACEPROC)                                        \
  X(FrontFace, PFNGLFRONTFACEPROC)                                      \
  X(BlendFuncSeparate, PFNGLBLENDFUNCSEPARATEPROC)                      \
  X(PolygonOffset, PFNGLPOLYGONOFFSETPROC)                              \
  X(ColorMask, PFNGLCOLORMASKPROC)                                      \
  X(Finish, PFNGLFINISHPROC)                                            \
  X(PixelStorei, PFNGLPIXELSTOREIPROC)                                  \
  X(ReadPixels, PFNGLREADPIXELSPROC)                                    \
  X(ReadBuffer, PFNGLREADBUFFERPROC)                                    \
  X(DrawBuffers, PFNGLDRAWBUFFERSPROC)                                  \
  X(GenTextures, PFNGLGENTEXTURESPROC)                                  \
  X(DeleteTextures, PFNGLDELETETEXTURESPROC)                            \
  X(BindTexture, PFNGLBINDTEXTUREPROC)                                  \
  X(ActiveTexture, PFNGLACTIVETEXTUREPROC)                              \
  X(TexStorage2D, PFNGLTEXSTORAGE2DPROC)                                \
  X(TexStorage3D, PFNGLTEXSTORAGE3DPROC)                                \
  X(TexStorage2DMultisample, PFNGLTEXSTORAGE2DMULTISAMPLEPROC)          \
  X(TexSubImage2D, PFNGLTEXSUBIMAGE2DPROC)                              \
  X(TexSubImage3D, PFNGLTEXSUBIMAGE3DPROC)                              \
  X(TexParameteri, PFNGLTEXPARAMETERIPROC)                              \
  X(GenerateMipmap, PFNGLGENERATEMIPMAPPROC)                            \
  X(GenFramebuffers, PFNGLGENFRAMEBUFFERSPROC)                          \
  X(DeleteFramebuffers, PFNGLDELETEFRAMEBUFFERSPROC)                    \
  X(BindFramebuffer, PFNGLBINDFRAMEBUFFERPROC)                          \
  X(FramebufferTexture2D, PFNGLFRAMEBUFFERTEXTURE2DPROC)                \
  X(CheckFramebufferStatus, PFNGLCHECKFRAMEBUFFERSTATUSPROC)            \
  X(GenRenderbuffers, PFNGLGENRENDERBUFFERSPROC)                        \
  X(DeleteRenderbuffers, PFNGLDELETERENDERBUFFERSPROC)                  \
  X(BindRenderbuffer, PFNGLBINDRENDERBUFFERPROC)                        \
  X(RenderbufferStorageMultisample, PFNGLRENDERBUFFERSTORAGEMULTISAMPLEPROC) \
  X(FramebufferRenderbuffer, PFNGLFRAMEBUFFERRENDERBUFFERPROC)          \
  X(GenBuffers, PFNGLGENBUFFERSPROC)                                    \
  X(DeleteBuffers, PFNGLDELETEBUFFERSPROC)                              \
  X(BindBuffer, PFNGLBINDBUFFERPROC)                                    \
  X(BufferData, PFNGLBUFFERDATAPROC)                                    \
  X(BufferSubData, PFNGLBUFFERSUBDATAPROC)                              \
  X(BindBufferBase, PFNGLBINDBUFFERBASEPROC)                            \
  X(BindBufferRange, PFNGLBINDBUFFERRANGEPROC)                          \
  X(GenVertexArrays, PFNGLGENVERTEXARRAYSPROC)                          \
  X(DeleteVertexArrays, PFNGLDELETEVERTEXARRAYSPROC)                    \
  X(BindVertexArray, PFNGLBINDVERTEXARRAYPROC)                          \
  X(EnableVertexAttribArray, PFNGLENABLEVERTEXATTRIBARRAYPROC)          \
  X(VertexAttribPointer, PFNGLVERTEXATTRIBPOINTERPROC)                  \
  X(DrawElements, PFNGLDRAWELEMENTSPROC)                                \
  X(DrawArrays, PFNGLDRAWARRAYSPROC)                                    \
  X(CreateShader, PFNGLCREATESHADERPROC)                                \
  X(ShaderSource, PFNGLSHADERSOURCEPROC)                                \
  X(CompileShader, PFNGLCOMPILESHADERPROC)                              \
  X(GetShaderiv, PFNGLGETSHADERIVPROC)                                  \
  X(GetShaderInfoLog, PFNGLGETSHADERINFOLOGPROC)                        \
  X(DeleteShader, PFNGLDELETESHADERPROC)                                \
  X(CreateProgram, PFNGLCREATEPROGRAMPROC)                              \
  X(AttachShader, PFNGLATTACHSHADERPROC)                                \
  X(LinkProgram, PFNGLLINKPROGRAMPROC)                                  \
  X(GetProgramiv, PFNGLGETPROGRAMIVPROC)                                \
  X(GetProgramInfoLog, PFNGLGETPROGRAMINFOLOGPROC)                      \
  X(DeleteProgram, PFNGLDELETEPROGRAMPROC)                              \
  X(UseProgram, PFNGLUSEPROGRAMPROC)                                    \
  X(GetUniformLocation, PFNGLGETUNIFORMLOCATIONPROC)                    \
  X(GetUniformBlockIndex, PFNGLGETUNIFORMBLOCKINDEXPROC)                \
  X(GetActiveUniformBlockiv, PFNGLGETACTIVEUNIFORMBLOCKIVPROC)          \
  X(UniformBlockBinding, PFNGLUNIFORMBLOCKBINDINGPROC)                  \
  X(Uniform1i, PFNGLUNIFORM1IPROC)                                      \
  X(Uniform2i, PFNGLUNIFORM2IPROC)                                      \
  X(Uniform1f, PFNGLUNIFORM1FPROC)                                      \
  X(Uniform3f, PFNGLUNIFORM3FPROC)

namespace hdrd::shading {

struct GlApi {
#define HDRD_GL_MEMBER(name, type) type name = nullptr;
  HDRD_GL_FUNCTIONS(HDRD_GL_MEMBER)
#undef HDRD_GL_MEMBER

  bool gles = false;  // GLES 3.2 context (else desktop GL 4.5 core)

  // Fills every entry through `get_proc` ("glClear" -> address). Returns the name of
  // the first entry point that could not be found, or an empty string.
  using GetProc = void* (*)(const char* name);
  std::string load(GetProc get_proc);
};

}  // namespace hdrd::shading
