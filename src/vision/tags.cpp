// The printed pattern: where its tags' corners are (pattern_corners), the sheet's picture
// (pattern_sheet, from libapriltag's tag bitmaps) and finding the tags in a picture.
#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>
#include <apriltag/tag36h11.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include <fmt/format.h>

#include "scaratwin/vision/webcam.hpp"

namespace scaratwin {
namespace {

// tag36h11: an 8 x 8-cell black square (the code inside its 6 x 6 cells) in a one-cell white
// border: 10 x 10 cells in all.
constexpr int kCellsAcross = 8;
constexpr int kCellsWithBorder = 10;

// Tags with a corner closer than this to the picture's edge are dropped (pixels).
constexpr double kEdgeMarginPx = 3.0;

double pitch_m(const PatternModel& p) { return p.tag_size_m + p.spacing_m; }

// Centre of tag (column c, row r) in the board's frame (row 0 at the board's +y side).
std::array<double, 2> tag_centre(const PatternModel& p, int c, int r) {
  return {(c - 0.5 * (p.columns - 1)) * pitch_m(p), (0.5 * (p.rows - 1) - r) * pitch_m(p)};
}

struct Family {
  apriltag_family_t* f = tag36h11_create();
  ~Family() { tag36h11_destroy(f); }
};

}  // namespace

std::vector<PatternTag> pattern_corners(const RobotModel& model) {
  const PatternModel& p = model.scene.pattern;
  const double z = model.scene.table_z_m + p.thickness_m;
  const double c = std::cos(p.yaw_rad), s = std::sin(p.yaw_rad);
  const double h = 0.5 * p.tag_size_m;
  // the corners' order of detect_tags(): (-x,-y), (+x,-y), (+x,+y), (-x,+y) of the tag
  static constexpr double kSign[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  std::vector<PatternTag> out;
  for (int r = 0; r < p.rows; ++r) {
    for (int col = 0; col < p.columns; ++col) {
      PatternTag t;
      t.id = r * p.columns + col;
      const auto centre = tag_centre(p, col, r);
      for (int k = 0; k < 4; ++k) {
        const double bx = centre[0] + kSign[k][0] * h, by = centre[1] + kSign[k][1] * h;
        t.p_B[k] = {p.x_m + c * bx - s * by, p.y_m + s * bx + c * by, z};
      }
      out.push_back(t);
    }
  }
  return out;
}

std::array<double, 2> pattern_sheet_size_m(const PatternModel& p) {
  const double cell = p.tag_size_m / kCellsAcross;
  return {p.columns * pitch_m(p) - p.spacing_m + 2 * cell,
          p.rows * pitch_m(p) - p.spacing_m + 2 * cell};
}

Result<PatternSheet> pattern_sheet(const PatternModel& p, int texels_per_cell) {
  const double cell = p.tag_size_m / kCellsAcross;
  PatternSheet sheet;
  const auto size = pattern_sheet_size_m(p);
  sheet.width_m = size[0];
  sheet.height_m = size[1];
  const double texel = cell / std::max(texels_per_cell, 1);
  const long w = std::lround(sheet.width_m / texel), h = std::lround(sheet.height_m / texel);
  if (texels_per_cell < 1 || w > 4096 || h > 4096) {
    return Error{VisionError::kBadPattern,
                 fmt::format("pattern_sheet: {} texels per tag cell give a {}x{} picture: "
                             "use 1 or more, and at most 4096 pixels each way",
                             texels_per_cell, w, h)};
  }
  Family fam;
  std::vector<image_u8_t*> bitmaps;
  for (int id = 0; id < p.columns * p.rows; ++id) bitmaps.push_back(apriltag_to_image(fam.f, id));
  RgbImage& img = sheet.image;
  img.width = static_cast<int>(w);
  img.height = static_cast<int>(h);
  img.rgb.assign(static_cast<std::size_t>(w * h * 3), 255);
  const double half_cells = 0.5 * kCellsWithBorder;
  for (int j = 0; j < img.height; ++j) {
    for (int i = 0; i < img.width; ++i) {
      // this texel's centre in the board's frame
      const double x = -0.5 * sheet.width_m + (i + 0.5) * sheet.width_m / img.width;
      const double y = 0.5 * sheet.height_m - (j + 0.5) * sheet.height_m / img.height;
      const int c = std::clamp(
          static_cast<int>(std::lround(x / pitch_m(p) + 0.5 * (p.columns - 1))), 0, p.columns - 1);
      const int r = std::clamp(static_cast<int>(std::lround(0.5 * (p.rows - 1) - y / pitch_m(p))),
                               0, p.rows - 1);
      const auto centre = tag_centre(p, c, r);
      // the tag's bitmap: column to the board's +x, row 0 at its +y side
      const int bc = static_cast<int>(std::floor((x - centre[0]) / cell + half_cells));
      const int br = static_cast<int>(std::floor((centre[1] - y) / cell + half_cells));
      if (bc < 0 || br < 0 || bc >= kCellsWithBorder || br >= kCellsWithBorder) continue;
      const image_u8_t* b = bitmaps[static_cast<std::size_t>(r * p.columns + c)];
      const std::uint8_t v = b->buf[br * b->stride + bc];
      std::uint8_t* o = &img.rgb[3 * (static_cast<std::size_t>(j) * img.width + i)];
      o[0] = o[1] = o[2] = v;
    }
  }
  for (image_u8_t* b : bitmaps) image_u8_destroy(b);
  return sheet;
}

std::vector<TagCorners> detect_tags(const RgbImage& image) {
  std::vector<TagCorners> out;
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() < static_cast<std::size_t>(image.width) * image.height * 3) {
    return out;
  }
  image_u8_t* grey =
      image_u8_create(static_cast<unsigned>(image.width), static_cast<unsigned>(image.height));
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const std::uint8_t* p = &image.rgb[3 * (static_cast<std::size_t>(v) * image.width + u)];
      grey->buf[v * grey->stride + u] =
          static_cast<std::uint8_t>(std::lround(0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]));
    }
  }
  Family fam;
  apriltag_detector_t* td = apriltag_detector_create();
  // one corrected bit at most: a misread tag would be a corner in the wrong place
  apriltag_detector_add_family_bits(td, fam.f, 1);
  td->quad_decimate = 1.0f;  // full resolution: the corners' accuracy is the point
  td->refine_edges = 1;
  td->nthreads = 1;
  zarray_t* found = apriltag_detector_detect(td, grey);
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(found, i, &d);
    // a tag cut by the picture's edge has its quad's corners on the edge: not a tag's corners
    bool inside = true;
    for (int k = 0; k < 4; ++k) {
      inside = inside && d->p[k][0] >= kEdgeMarginPx && d->p[k][1] >= kEdgeMarginPx &&
               d->p[k][0] <= image.width - kEdgeMarginPx &&
               d->p[k][1] <= image.height - kEdgeMarginPx;
    }
    if (!inside) continue;
    TagCorners t;
    t.id = d->id;
    // libapriltag's pixel coordinates put pixel i at [i, i + 1) like ours
    for (int k = 0; k < 4; ++k) t.px[k] = {d->p[k][0], d->p[k][1]};
    out.push_back(t);
  }
  apriltag_detections_destroy(found);
  apriltag_detector_destroy(td);
  image_u8_destroy(grey);
  std::sort(out.begin(), out.end(),
            [](const TagCorners& a, const TagCorners& b) { return a.id < b.id; });
  return out;
}

}  // namespace scaratwin
