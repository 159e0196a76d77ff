#include "scaratwin/vision/vision.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

using Vec3 = std::array<double, 3>;

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 unit(const Vec3& a) {
  const double n = std::sqrt(dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}

// Focal length in pixels for an image `height` pixels high.
double focal_px(const CameraModel& c, int height) {
  return 0.5 * height / std::tan(0.5 * deg_to_rad(c.fovy_deg));
}

}  // namespace

Result<RgbImage> decode_png(const std::string& bytes) {
  return decode_png(std::span<const std::uint8_t>(
      reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
}

Result<RgbImage> decode_png(std::span<const std::uint8_t> bytes) {
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&img, bytes.data(), bytes.size())) {
    return Error{VisionError::kBadImage,
                 fmt::format("not a PNG image ({} bytes): {}", bytes.size(), img.message)};
  }
  img.format = PNG_FORMAT_RGB;
  RgbImage out;
  out.width = static_cast<int>(img.width);
  out.height = static_cast<int>(img.height);
  out.rgb.resize(PNG_IMAGE_SIZE(img));
  if (!png_image_finish_read(&img, nullptr, out.rgb.data(), 0, nullptr)) {
    png_image_free(&img);
    return Error{VisionError::kBadImage, fmt::format("cannot decode PNG: {}", img.message)};
  }
  return out;
}

CameraAxes camera_axes(const CameraModel& cam) {
  const Vec3 f = unit(sub(cam.look_at_m, cam.pos_m));
  const Vec3 up_hint = std::abs(f[2]) > 0.999 ? Vec3{1, 0, 0} : Vec3{0, 0, 1};
  CameraAxes a;
  a.x = unit(cross(f, up_hint));
  a.y = cross(a.x, f);
  a.z = {-f[0], -f[1], -f[2]};
  // the roll turns the camera about its own z axis
  if (cam.roll_rad != 0.0) {
    const double c = std::cos(cam.roll_rad), s = std::sin(cam.roll_rad);
    const Vec3 x = a.x, y = a.y;
    for (int i = 0; i < 3; ++i) {
      a.x[i] = c * x[i] + s * y[i];
      a.y[i] = -s * x[i] + c * y[i];
    }
  }
  return a;
}

bool project(const CameraModel& cam, int width_px, int height_px, const Vec3& p, double& col,
             double& row) {
  const CameraAxes a = camera_axes(cam);
  const Vec3 d = sub(p, cam.pos_m);
  const double depth = -dot(d, a.z);
  if (!(depth > 1e-9)) return false;
  const double f = focal_px(cam, height_px);
  col = 0.5 * width_px + f * dot(d, a.x) / depth;
  row = 0.5 * height_px - f * dot(d, a.y) / depth;
  return true;
}

bool project(const CameraModel& cam, const Vec3& p, double& col, double& row) {
  return project(cam, cam.width_px, cam.height_px, p, col, row);
}

bool unproject_to_plane(const CameraModel& cam, double col, double row, double plane_z, Vec3& p) {
  const CameraAxes a = camera_axes(cam);
  const double f = focal_px(cam, cam.height_px);
  const double u = (col - 0.5 * cam.width_px) / f;
  const double v = (0.5 * cam.height_px - row) / f;
  // ray direction in B: u x + v y - z.
  const Vec3 dir{u * a.x[0] + v * a.y[0] - a.z[0], u * a.x[1] + v * a.y[1] - a.z[1],
                 u * a.x[2] + v * a.y[2] - a.z[2]};
  if (std::abs(dir[2]) < 1e-12) return false;
  const double t = (plane_z - cam.pos_m[2]) / dir[2];
  if (!(t > 0.0)) return false;
  p = {cam.pos_m[0] + t * dir[0], cam.pos_m[1] + t * dir[1], plane_z};
  return true;
}

std::vector<CubeDetection> detect_cubes(const RgbImage& img, const RobotModel& model,
                                        const DetectOptions& o) {
  std::vector<CubeDetection> out;
  const int w = img.width, h = img.height;
  if (w <= 0 || h <= 0 || img.rgb.size() < static_cast<size_t>(w) * h * 3) return out;
  // label each pixel with the colour that dominates it (-1: none).
  std::vector<int8_t> label(static_cast<size_t>(w) * h, -1);
  for (int i = 0; i < w * h; ++i) {
    const double c[3] = {img.rgb[3 * i] / 255.0, img.rgb[3 * i + 1] / 255.0,
                         img.rgb[3 * i + 2] / 255.0};
    for (int k = 0; k < 3; ++k) {
      if (c[k] >= o.min_channel && c[k] >= o.dominance * c[(k + 1) % 3] &&
          c[k] >= o.dominance * c[(k + 2) % 3]) {
        label[static_cast<size_t>(i)] = static_cast<int8_t>(k);
      }
    }
  }
  // the camera model at this picture's size.
  CameraModel cam = model.scene.camera;
  cam.width_px = w;
  cam.height_px = h;
  const double top_z = model.scene.table_z_m + model.scene.cube_size_m;
  std::vector<int> stack;
  for (int start = 0; start < w * h; ++start) {
    const int k = label[static_cast<size_t>(start)];
    if (k < 0) continue;
    // flood fill one 4-connected blob, clearing its labels.
    double sc = 0.0, sr = 0.0;
    int area = 0;
    stack.assign(1, start);
    label[static_cast<size_t>(start)] = -1;
    while (!stack.empty()) {
      const int p = stack.back();
      stack.pop_back();
      const int x = p % w, y = p / w;
      sc += x + 0.5;
      sr += y + 0.5;
      ++area;
      const int nb[4] = {x > 0 ? p - 1 : -1, x + 1 < w ? p + 1 : -1, y > 0 ? p - w : -1,
                         y + 1 < h ? p + w : -1};
      for (int q : nb) {
        if (q >= 0 && label[static_cast<size_t>(q)] == k) {
          label[static_cast<size_t>(q)] = -1;
          stack.push_back(q);
        }
      }
    }
    if (area < o.min_area_px) continue;
    CubeDetection d;
    d.color = static_cast<CubeColor>(k);
    d.col = sc / area;
    d.row = sr / area;
    d.area_px = area;
    // the camera sees mostly the top face: put the centroid on the top-face plane.
    Vec3 p;
    if (!unproject_to_plane(cam, d.col, d.row, top_z, p)) continue;
    d.x_m = p[0];
    d.y_m = p[1];
    out.push_back(d);
  }
  std::sort(out.begin(), out.end(), [](const CubeDetection& a, const CubeDetection& b) {
    if (a.color != b.color) return a.color < b.color;
    return a.area_px > b.area_px;
  });
  return out;
}

namespace {

// Centroid of the pixels whose channels (a, b, c) = (rgb[ia], rgb[ib], rgb[ic]) have a and b
// at least `lo` and c below `ratio` of the smaller of a and b; none when one of them is on the
// picture's edge (a disc cut by the edge has its centroid off its centre).
bool centroid_of(const RgbImage& image, int ia, int ib, int ic, double min_channel, double ratio,
                 int min_area_px, double& col, double& row) {
  const double lo = 255.0 * min_channel;
  double su = 0.0, sv = 0.0;
  int n = 0;
  bool on_edge = false;
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const std::uint8_t* p = &image.rgb[3 * (static_cast<std::size_t>(v) * image.width + u)];
      const double a = p[ia], b = p[ib], c = p[ic];
      if (a >= lo && b >= lo && c < ratio * std::min(a, b)) {
        su += u + 0.5;
        sv += v + 0.5;
        ++n;
        on_edge = on_edge || u == 0 || v == 0 || u == image.width - 1 || v == image.height - 1;
      }
    }
  }
  if (n < min_area_px || on_edge) return false;
  col = su / n;
  row = sv / n;
  return true;
}

}  // namespace

bool detect_marker(const RgbImage& image, double& col, double& row, int min_area_px,
                   double min_channel, double green_ratio) {
  return centroid_of(image, 0, 2, 1, min_channel, green_ratio, min_area_px, col, row);
}

bool detect_flag_marker(const RgbImage& image, double& col, double& row, int min_area_px,
                        double min_channel, double red_ratio) {
  return centroid_of(image, 1, 2, 0, min_channel, red_ratio, min_area_px, col, row);
}

}  // namespace scaratwin
