#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "gel/analysis/pictures.hpp"
#include "gel/errors.hpp"

namespace gel::analysis {
namespace {

void set_colour(cairo_t* cr, const Rgb& c) { cairo_set_source_rgb(cr, c.r, c.g, c.b); }

// The longest of 1, 2, 5, 10, 20, 50, ... a that is at most a fifth of the box width: long
// enough to read, short enough to fit in a corner.
double scale_bar_length(double box_width) {
  double length = 1;
  for (double decade = 1; decade * 1 <= box_width / 5; decade *= 10)
    for (double mantissa : {1.0, 2.0, 5.0})
      if (mantissa * decade <= box_width / 5) length = mantissa * decade;
  return length;
}

// A scale bar with its length above it ("10 a", the unit in italics) in the corner of the
// region between the walls that the fewest particles (and the xi circle) reach, on a white
// backing so that it stays readable where every corner is crowded. Device units;
// `region_top` and `region_bottom` bound the region between the walls; the xi circle, when
// there is one, is centred in the picture with radius `circle_radius`.
void draw_scale_bar(cairo_t* cr, const Configuration& config, double scale, double width, double height, double y0,
                    double region_top, double region_bottom, double circle_radius) {
  const double length = scale_bar_length(config.lx);
  const double bar_width = length * scale;
  const double font = std::max(10.0, 0.024 * std::max(width, height));
  const double thickness = std::max(2.0, 0.25 * font), pad = 0.35 * font, inset = 0.5 * font;
  char number[32];
  std::snprintf(number, sizeof number, "%g ", length);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, font);
  cairo_text_extents_t number_extents, unit_extents;
  cairo_text_extents(cr, number, &number_extents);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_ITALIC, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_text_extents(cr, "a", &unit_extents);
  const double text_width = number_extents.x_advance + unit_extents.x_advance;
  const double box_width = std::max(bar_width, text_width) + 2 * pad, box_height = font + 0.4 * font + thickness + 2 * pad;
  if (box_width + 2 * inset > width || box_height + 2 * inset > region_bottom - region_top) return;

  // Candidates in order of preference: the corners, then along the bottom and top edges; the
  // first with the fewest particles under it wins.
  const double left = inset, right = width - inset - box_width;
  const double top = region_top + inset, bottom = region_bottom - inset - box_height;
  std::vector<std::pair<double, double>> candidates = {{right, bottom}, {left, bottom}, {right, top}, {left, top}};
  for (double x = right - 0.5 * box_width; x > left; x -= 0.5 * box_width) candidates.push_back({x, bottom});
  for (double x = right - 0.5 * box_width; x > left; x -= 0.5 * box_width) candidates.push_back({x, top});
  const double radius = scale;  // a particle's radius in device units
  auto particles_under = [&](double bx, double by) {
    int count = 0;
    for (std::size_t p = 0; p < config.size(); ++p)
      for (int image = -1; image <= 1; ++image) {
        const double px = (config.x[p] + image * config.lx) * scale, py = height - (config.y[p] - y0) * scale;
        const double nearest_x = std::clamp(px, bx, bx + box_width), nearest_y = std::clamp(py, by, by + box_height);
        if (std::hypot(px - nearest_x, py - nearest_y) < radius) ++count;
      }
    if (circle_radius > 0) {  // the circle's line crosses the box
      const double cx = 0.5 * width, cy = 0.5 * height;
      const double nearest = std::hypot(cx - std::clamp(cx, bx, bx + box_width), cy - std::clamp(cy, by, by + box_height));
      const double farthest = std::hypot(std::max(std::abs(cx - bx), std::abs(cx - bx - box_width)),
                                         std::max(std::abs(cy - by), std::abs(cy - by - box_height)));
      if (nearest <= circle_radius && circle_radius <= farthest) ++count;
    }
    return count;
  };
  std::pair<double, double> chosen = candidates[0];
  int fewest = particles_under(chosen.first, chosen.second);
  for (const auto& candidate : candidates) {
    if (fewest == 0) break;
    const int count = particles_under(candidate.first, candidate.second);
    if (count < fewest) fewest = count, chosen = candidate;
  }
  const auto [bx, by] = chosen;
  cairo_set_source_rgba(cr, 1, 1, 1, 0.85);
  cairo_rectangle(cr, bx, by, box_width, box_height);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
  const double centre = bx + 0.5 * box_width;
  cairo_rectangle(cr, centre - 0.5 * bar_width, by + box_height - pad - thickness, bar_width, thickness);
  cairo_fill(cr);
  cairo_move_to(cr, centre - 0.5 * text_width, by + pad + font);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_show_text(cr, number);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_ITALIC, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_show_text(cr, "a");
}

// Draws in configuration units: x to the right, y up, origin at the lower-left corner of the
// region; `scale` device units per a.
void draw(cairo_t* cr, const Configuration& config, const SnapshotStyle& style, double scale, double width,
          double height, double y0) {
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_save(cr);
  cairo_translate(cr, 0, height);
  cairo_scale(cr, scale, -scale);
  cairo_translate(cr, 0, -y0);
  cairo_rectangle(cr, 0, y0, config.lx, height / scale);
  cairo_clip(cr);
  const double lx = config.lx;
  // Disks, with the image across the periodic x boundary when they cross it (and across y when
  // periodic in y).
  const bool periodic_y = config.periodic_y && !config.has_walls();
  auto for_images = [&](double x, double y, double reach, auto&& fn) {
    for (int ix = -1; ix <= 1; ++ix)
      for (int iy = periodic_y ? -1 : 0; iy <= (periodic_y ? 1 : 0); ++iy) {
        const double px = x + ix * lx, py = y + iy * config.ly;
        if (px + reach < 0 || px - reach > lx) continue;
        if (periodic_y && (py + reach < 0 || py - reach > config.ly)) continue;
        fn(px, py);
      }
  };
  for (std::size_t p = 0; p < config.size(); ++p) {
    const bool on_wall = config.has_walls() && config.wall[p] != kNoWall;
    set_colour(cr, on_wall ? kWallParticleColour : kParticleColour);
    for_images(config.x[p], config.y[p], 1.0, [&](double px, double py) {
      cairo_new_sub_path(cr);
      cairo_arc(cr, px, py, 1.0, 0, 2 * M_PI);
    });
    cairo_fill(cr);
  }
  if (style.bonds && !config.bonds.empty()) {
    set_colour(cr, kBondColour);
    cairo_set_line_width(cr, 0.25);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    for (const auto& b : config.bonds) {
      double dx, dy;
      config.separation(b.i, b.j, dx, dy);
      // From each end towards the other by the minimum image: a bond across the boundary shows
      // as two halves, one at each side.
      for (auto [from, sign] : {std::pair{b.i, 1.0}, std::pair{b.j, -1.0}}) {
        const double x = config.x[from], y = config.y[from];
        for_images(x, y, 2.5, [&](double px, double py) {
          cairo_move_to(cr, px, py);
          cairo_line_to(cr, px + 0.5 * sign * dx, py + 0.5 * sign * dy);
        });
      }
    }
    cairo_stroke(cr);
  }
  if (config.has_walls()) {
    cairo_set_source_rgb(cr, 0.45, 0.45, 0.45);
    cairo_rectangle(cr, 0, config.wall_bottom - 1.0, lx, 1.0);
    cairo_rectangle(cr, 0, config.wall_top, lx, 1.0);
    cairo_fill(cr);
  }
  if (style.xi_circle && *style.xi_circle > 0) {
    cairo_set_source_rgb(cr, 0.95, 0.55, 0.05);
    cairo_set_line_width(cr, std::max(0.4, 3.0 / scale));
    const double cy = y0 + 0.5 * height / scale;
    cairo_arc(cr, 0.5 * lx, cy, 2.0 * *style.xi_circle, 0, 2 * M_PI);
    cairo_stroke(cr);
  }
  cairo_restore(cr);
  if (style.scale_bar) {
    const double region_top = config.has_walls() ? height - (config.wall_top - y0) * scale : 0.0;
    const double region_bottom = config.has_walls() ? height - (config.wall_bottom - y0) * scale : height;
    const double circle_radius = style.xi_circle && *style.xi_circle > 0 ? 2.0 * *style.xi_circle * scale : 0.0;
    draw_scale_bar(cr, config, scale, width, height, y0, region_top, region_bottom, circle_radius);
  }
  if (!style.title.empty()) {
    // On a white label so that it stays readable over particles.
    const double font = std::max(10.0, 0.022 * std::max(width, height));
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, font);
    cairo_text_extents_t extents;
    cairo_text_extents(cr, style.title.c_str(), &extents);
    cairo_set_source_rgba(cr, 1, 1, 1, 0.85);
    cairo_rectangle(cr, 4, 4, extents.x_advance + 8, font * 1.4);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_move_to(cr, 8, 4 + font * 1.05);
    cairo_show_text(cr, style.title.c_str());
  }
}

}  // namespace

void render_snapshot(const Configuration& config, const std::string& path, const SnapshotStyle& style) {
  const PictureFormat format = picture_format_of_path(path);
  const bool png = format == PictureFormat::png;
  if (style.size < 16 || style.size > 20000) throw InvalidArgument("size", "picture size must be 16..20000");
  const double region_height = config.height();
  if (!(config.lx > 0 && region_height > 0)) throw InvalidArgument("configuration", "box has no positive size");
  // Between walls, one radius of margin above and below shows the wall bars.
  const double margin = config.has_walls() ? 1.0 : 0.0;
  const double y0 = (config.has_walls() ? config.wall_bottom : 0.0) - margin;
  const double shown_height = region_height + 2 * margin;
  const double scale = style.size / std::max(config.lx, shown_height);
  const int width = std::max(1, static_cast<int>(std::lround(config.lx * scale)));
  const int height = std::max(1, static_cast<int>(std::lround(shown_height * scale)));
  cairo_surface_t* surface = format == PictureFormat::svg   ? cairo_svg_surface_create(path.c_str(), width, height)
                             : format == PictureFormat::pdf ? cairo_pdf_surface_create(path.c_str(), width, height)
                                                            : cairo_image_surface_create(CAIRO_FORMAT_RGB24, width, height);
  std::unique_ptr<cairo_surface_t, void (*)(cairo_surface_t*)> surface_guard(surface, cairo_surface_destroy);
  if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error("cairo cannot create '" + path + "': " + cairo_status_to_string(cairo_surface_status(surface)));
  cairo_t* cr = cairo_create(surface);
  if (!style.antialias) cairo_set_antialias(cr, CAIRO_ANTIALIAS_NONE);
  draw(cr, config, style, scale, width, height, y0);
  const cairo_status_t status = cairo_status(cr);
  cairo_destroy(cr);
  if (status != CAIRO_STATUS_SUCCESS) throw std::runtime_error(std::string("cairo: ") + cairo_status_to_string(status));
  if (png) {
    const cairo_status_t written = cairo_surface_write_to_png(surface, path.c_str());
    if (written != CAIRO_STATUS_SUCCESS)
      throw std::runtime_error("cannot write '" + path + "': " + cairo_status_to_string(written));
  } else {
    cairo_surface_finish(surface);
    if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS)
      throw std::runtime_error("cannot write '" + path + "': " + cairo_status_to_string(cairo_surface_status(surface)));
  }
}

}  // namespace gel::analysis
