// Offscreen rendering of the overhead camera: EGL on Mesa's surfaceless platform, MuJoCo's
// renderer into its offscreen framebuffer, rows flipped to top-first.
#include "scaratwin/sim/camera.hpp"

#include "scaratwin/vision/vision.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include "mj_guard.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {
namespace {

Error render_error(std::string message) {
  return Error{static_cast<int>(SimError::kRender), std::move(message)};
}

// What a machine without Mesa's EGL vendor library or its software rasterizer lacks (libglvnd
// loads them at run time, so no linked library names them).
constexpr const char* kInstallMesa =
    ": the camera renders through Mesa's EGL and software rasterizer; install libegl-mesa0 "
    "and libgl1-mesa-dri (or run without the camera: scaratwin-sim --no-camera, "
    "scaratwin-robot --camera-port -1)";

// The process's EGL display on Mesa's surfaceless platform, initialised once. EGL returns the
// same display to every caller, so terminating it would break other cameras.
Result<EGLDisplay> shared_display() {
  static std::mutex mutex;
  static EGLDisplay display = EGL_NO_DISPLAY;
  std::lock_guard lock(mutex);
  if (display != EGL_NO_DISPLAY) return display;
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr) {
    return render_error(fmt::format("EGL has no eglGetPlatformDisplayEXT{}", kInstallMesa));
  }
  EGLDisplay d = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (d == EGL_NO_DISPLAY || eglInitialize(d, &major, &minor) != EGL_TRUE) {
    return render_error(fmt::format("EGL surfaceless display unavailable (EGL error 0x{:x}){}",
                                    eglGetError(), kInstallMesa));
  }
  display = d;
  return display;
}

}  // namespace

struct Camera::Impl {
  std::mutex mutex;
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  mjvScene scene;
  mjvOption option;
  mjvCamera camera;
  mjvPerturb perturb;
  mjrContext con;
  bool scene_made = false;
  bool con_made = false;
  bool captured = false;
  int max_w = 0, max_h = 0;
  std::vector<std::uint8_t> flipped;

  bool make_current() {
    return eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context) == EGL_TRUE;
  }
  void release_current() {
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }

  ~Impl() {
    if (display == EGL_NO_DISPLAY) return;
    if (context != EGL_NO_CONTEXT && make_current()) {
      if (con_made) mjr_freeContext(&con);
      release_current();
    }
    if (scene_made) mjv_freeScene(&scene);
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    // the display is shared by every camera of the process and stays initialised
  }
};

Camera::Camera() : impl_(std::make_unique<Impl>()) {}
Camera::~Camera() = default;

Result<std::unique_ptr<Camera>> Camera::create(const Simulation& sim,
                                               const RenderOptions& options) {
  std::unique_ptr<Camera> cam(new Camera());
  Impl& c = *cam->impl_;
  const mjModel* m = sim.model();

  // EGL: Mesa's surfaceless platform, a pbuffer-capable config, desktop OpenGL, no surface
  auto display = shared_display();
  if (!display) return display.error();
  c.display = *display;
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_ALPHA_SIZE,
                                   8,
                                   EGL_DEPTH_SIZE,
                                   24,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint n = 0;
  if (eglChooseConfig(c.display, config_attribs, &config, 1, &n) != EGL_TRUE || n < 1) {
    return render_error(
        fmt::format("no EGL config with RGBA8, depth 24 and pbuffers (0x{:x})", eglGetError()));
  }
  if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE) return render_error("eglBindAPI(OpenGL) failed");
  c.context = eglCreateContext(c.display, config, EGL_NO_CONTEXT, nullptr);
  if (c.context == EGL_NO_CONTEXT) {
    return render_error(fmt::format("eglCreateContext failed (0x{:x})", eglGetError()));
  }
  if (!c.make_current()) {
    return render_error(fmt::format("eglMakeCurrent failed (0x{:x})", eglGetError()));
  }

  struct Make {
    const mjModel* m;
    Impl* c;
    void operator()() {
      mjv_defaultScene(&c->scene);
      mjv_makeScene(m, &c->scene, 2000);
      c->scene_made = true;
      mjv_defaultOption(&c->option);
      mjv_defaultCamera(&c->camera);
      mjv_defaultPerturb(&c->perturb);
      mjr_defaultContext(&c->con);
      mjr_makeContext(m, &c->con, mjFONTSCALE_50);
      c->con_made = true;
      mjr_setBuffer(mjFB_OFFSCREEN, &c->con);
    }
  } make{m, &c};
  Status st =
      detail::mj_guarded(static_cast<int>(SimError::kRender), "creating the renderer", make);
  if (st && c.con.currentBuffer != mjFB_OFFSCREEN) {
    st = render_error("MuJoCo has no offscreen framebuffer on this GL context");
  }
  c.release_current();
  if (!st) return st.error();
  c.camera.type = mjCAMERA_FIXED;
  c.camera.fixedcamid = mj_name2id(m, mjOBJ_CAMERA, kCameraName);
  SCARATWIN_CHECK(c.camera.fixedcamid >= 0, "generated model lacks the overhead camera");
  c.scene.flags[mjRND_SHADOW] = options.shadows ? 1 : 0;
  c.scene.flags[mjRND_REFLECTION] = 0;
  c.scene.flags[mjRND_SKYBOX] = 0;
  // only what a real camera sees: no sites, no joints, no frames
  c.option.sitegroup[0] = c.option.sitegroup[1] = c.option.sitegroup[2] = 0;
  c.max_w = c.con.offWidth;
  c.max_h = c.con.offHeight;
  return cam;
}

int Camera::max_width_px() const { return impl_->max_w; }
int Camera::max_height_px() const { return impl_->max_h; }

Status Camera::capture(const Simulation& sim) {
  Impl& c = *impl_;
  std::lock_guard lock(c.mutex);
  struct Update {
    const mjModel* m;
    mjData* d;
    Impl* c;
    void operator()() {
      mjv_updateScene(m, d, &c->option, &c->perturb, &c->camera, mjCAT_ALL, &c->scene);
    }
  } update{sim.model(), const_cast<mjData*>(sim.data()), &c};
  // mjv_updateScene reads the data only; the cast is for its C signature
  Status st = detail::mj_guarded(static_cast<int>(SimError::kRender), "mjv_updateScene", update);
  c.captured = st.ok();
  return st;
}

Result<Image> Camera::draw(int width_px, int height_px) {
  Impl& c = *impl_;
  if (width_px < 1 || height_px < 1 || width_px > c.max_w || height_px > c.max_h) {
    return render_error(
        fmt::format("image size {}x{}: must be 1x1 up to {}x{} (the offscreen "
                    "buffer; raise it with --max-image)",
                    width_px, height_px, c.max_w, c.max_h));
  }
  std::lock_guard lock(c.mutex);
  if (!c.captured) return render_error("draw() before capture()");
  if (!c.make_current()) {
    return render_error(fmt::format("eglMakeCurrent failed (0x{:x})", eglGetError()));
  }
  Image img;
  img.width_px = width_px;
  img.height_px = height_px;
  const std::size_t row = static_cast<std::size_t>(width_px) * 3;
  c.flipped.resize(row * height_px);
  struct Draw {
    Impl* c;
    int w, h;
    void operator()() {
      const mjrRect viewport{0, 0, w, h};
      mjr_render(viewport, &c->scene, &c->con);
      mjr_readPixels(c->flipped.data(), nullptr, viewport, &c->con);
    }
  } draw{&c, width_px, height_px};
  Status st = detail::mj_guarded(static_cast<int>(SimError::kRender), "mjr_render", draw);
  c.release_current();
  if (!st) return st.error();
  // MuJoCo reads bottom-up; images are top-first
  img.rgb.resize(row * height_px);
  for (int r = 0; r < height_px; ++r) {
    std::memcpy(img.rgb.data() + r * row, c.flipped.data() + (height_px - 1 - r) * row, row);
  }
  return img;
}

Result<Image> Camera::render(const Simulation& sim, int width_px, int height_px) {
  if (Status st = capture(sim); !st) return st.error();
  return draw(width_px, height_px);
}

PixelPoint project(const CameraModel& camera, int width_px, int height_px,
                   const std::array<double, 3>& p) {
  PixelPoint out;
  if (!scaratwin::project(camera, width_px, height_px, p, out.u_px, out.v_px)) return out;
  out.visible = out.u_px >= 0 && out.u_px < width_px && out.v_px >= 0 && out.v_px < height_px;
  return out;
}

}  // namespace scaratwin::sim
