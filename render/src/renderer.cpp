#include "skinspec/render/renderer.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <optional>

#include "skinspec/render/bvh.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec::render {

namespace {

constexpr int kTile = 32;

// A pinhole camera's ray through a point of the image plane given in pixels.
class CameraRays {
 public:
  CameraRays(const Camera& camera, int width, int height) : origin_(camera.position), width_(width), height_(height) {
    forward_ = normalized(camera.target - camera.position);
    right_ = normalized(cross(forward_, camera.up));
    up_ = cross(right_, forward_);
    half_height_ = std::tan(camera.vertical_fov_degrees * std::numbers::pi / 360.0);
  }
  Ray through(double px, double py) const {
    const double aspect = static_cast<double>(width_) / height_;
    const double sx = (2.0 * px / width_ - 1.0) * half_height_ * aspect;
    const double sy = (1.0 - 2.0 * py / height_) * half_height_;
    return {origin_, normalized(forward_ + right_ * sx + up_ * sy)};
  }

 private:
  Vec3 origin_, forward_, right_, up_;
  int width_, height_;
  double half_height_ = 0;
};

class Tracer {
 public:
  Tracer(const Scene& scene, const SpectralColours& colours, const RenderSettings& settings)
      : scene_(scene),
        bvh_(scene.mesh),
        colours_(colours),
        settings_(settings),
        epsilon_(1e-5 * std::max(1.0, bounds_of(scene.mesh).radius())) {}

  // XYZ seen along a camera ray, or nothing when it leaves the scene.
  std::optional<Xyz> trace(const Ray& ray) const {
    const auto hit = bvh_.nearest(ray, 0, std::numeric_limits<double>::infinity());
    if (!hit) return std::nullopt;
    const Vec3 point = ray.origin + ray.direction * hit->distance;
    const Vec3 to_viewer = -ray.direction;
    const auto [geometric, shading] = normals_at(*hit, to_viewer);
    const Vec3 lifted = point + geometric * epsilon_;
    double body = 0, specular = 0;
    for (const Light& light : scene_.lights) {
      const auto [to_light, distance, irradiance] = towards(light, point);
      if (dot(geometric, to_light) <= 0) continue;
      if (settings_.shadows && bvh_.blocked({lifted, to_light}, 0, distance)) continue;
      const Shading s = torrance_sparrow(shading, to_light, to_viewer, settings_.surface);
      body += irradiance * s.body;
      specular += irradiance * s.specular;
    }
    const auto mix = [&](double b, double s) { return settings_.exposure * (body * b + specular * s); };
    return Xyz{mix(colours_.body.x, colours_.specular.x), mix(colours_.body.y, colours_.specular.y),
               mix(colours_.body.z, colours_.specular.z)};
  }

 private:
  struct Normals {
    Vec3 geometric, shading;
  };
  struct Towards {
    Vec3 direction;
    double distance, irradiance;
  };

  // Both normals turned to the viewer's side; the shading normal (interpolated from the
  // vertices) bent just far enough to face the viewer at silhouettes, where interpolation can
  // tip it away and would otherwise leave a black rim.
  Normals normals_at(const Hit& hit, const Vec3& to_viewer) const {
    const auto& tri = scene_.mesh.triangles[hit.triangle];
    const auto& p = scene_.mesh.positions;
    const auto& n = scene_.mesh.normals;
    Vec3 geometric = normalized(cross(p[tri[1]] - p[tri[0]], p[tri[2]] - p[tri[0]]));
    if (dot(geometric, to_viewer) < 0) geometric = -geometric;
    Vec3 shading = normalized(n[tri[0]] * (1 - hit.u - hit.v) + n[tri[1]] * hit.u + n[tri[2]] * hit.v);
    if (dot(shading, geometric) < 0) shading = -shading;
    constexpr double kMinFacing = 0.02;
    if (const double facing = dot(shading, to_viewer); facing < kMinFacing)
      shading = normalized(shading + to_viewer * (kMinFacing - facing));
    return {geometric, shading};
  }

  Towards towards(const Light& light, const Vec3& point) const {
    if (light.kind == Light::Kind::directional)
      return {normalized(light.vector), std::numeric_limits<double>::infinity(), light.intensity};
    const Vec3 offset = light.vector - point;
    const double d = length(offset);
    return {offset * (1.0 / d), d, light.intensity / (d * d)};
  }

  const Scene& scene_;
  Bvh bvh_;
  SpectralColours colours_;
  const RenderSettings& settings_;
  double epsilon_;
};

// Mean XYZ of the sub-pixel rays as linear sRGB; background where rays miss.
Rgb shade_pixel(const Tracer& tracer, const CameraRays& rays, const RenderSettings& settings, int x, int y) {
  const int n = settings.samples_per_side;
  double r = 0, g = 0, b = 0;
  for (int sy = 0; sy < n; ++sy)
    for (int sx = 0; sx < n; ++sx) {
      const auto xyz = tracer.trace(rays.through(x + (sx + 0.5) / n, y + (sy + 0.5) / n));
      const auto rgb = xyz ? xyz_to_linear_srgb(*xyz)
                           : std::array<double, 3>{static_cast<double>(settings.background.r),
                                                   static_cast<double>(settings.background.g),
                                                   static_cast<double>(settings.background.b)};
      r += rgb[0];
      g += rgb[1];
      b += rgb[2];
    }
  const double share = 1.0 / (n * n);
  return {static_cast<float>(r * share), static_cast<float>(g * share), static_cast<float>(b * share)};
}

std::expected<void, std::string> check_settings(const Scene& scene, const RenderSettings& settings) {
  if (settings.width < 1 || settings.height < 1 || settings.width > kMaxImageSide || settings.height > kMaxImageSide)
    return std::unexpected(fmt::format("image size {}x{} is outside 1x1..{}x{}", settings.width, settings.height,
                                       kMaxImageSide, kMaxImageSide));
  if (settings.samples_per_side < 1 || settings.samples_per_side > kMaxSamplesPerSide)
    return std::unexpected(fmt::format("samples per side must be 1..{}", kMaxSamplesPerSide));
  if (!(settings.exposure > 0 && std::isfinite(settings.exposure)))
    return std::unexpected(std::string("exposure must be positive"));
  const Camera& c = scene.camera;
  const Vec3 view = c.target - c.position;
  if (!(length(cross(view, c.up)) > 0 && std::isfinite(length(view)) && c.vertical_fov_degrees > 0 &&
        c.vertical_fov_degrees < 180))
    return std::unexpected(
        std::string("the camera needs a view direction not parallel to its up and a field of 0-180 degrees"));
  for (const Light& l : scene.lights)
    if (!(std::isfinite(l.intensity) && l.intensity >= 0 && std::isfinite(length(l.vector)) &&
          (l.kind == Light::Kind::point || length(l.vector) > 0)))
      return std::unexpected(
          std::string("a light needs a finite non-negative intensity and a finite, non-zero direction"));
  return check_surface(settings.surface);
}

}  // namespace

std::optional<std::pair<int, int>> parse_image_size(std::string_view text, int max_side) {
  int w = 0, h = 0;
  const char* last = text.data() + text.size();
  const auto [after_w, ec_w] = std::from_chars(text.data(), last, w);
  if (ec_w != std::errc{} || after_w == last || *after_w != 'x') return std::nullopt;
  const auto [after_h, ec_h] = std::from_chars(after_w + 1, last, h);
  if (ec_h != std::errc{} || after_h != last || w < 1 || h < 1 || w > max_side || h > max_side) return std::nullopt;
  return std::pair{w, h};
}

std::expected<void, std::string> check_surface(const SurfaceParams& s) {
  if (!(s.alpha >= 0 && std::isfinite(s.alpha)))
    return std::unexpected(fmt::format("alpha must be >= 0, not {}", s.alpha));
  if (!(s.beta >= 0 && std::isfinite(s.beta))) return std::unexpected(fmt::format("beta must be >= 0, not {}", s.beta));
  if (!(s.roughness > 0 && s.roughness <= std::numbers::pi / 2))
    return std::unexpected(fmt::format("roughness must be in (0, pi/2] radians, not {}", s.roughness));
  if (!(s.index > 1 && s.index <= 5))
    return std::unexpected(fmt::format("refractive index must be in (1, 5], not {}", s.index));
  return {};
}

std::expected<Image, std::string> render(const Scene& scene, const SpectralColours& colours,
                                         const RenderSettings& settings) {
  if (auto ok = check_settings(scene, settings); !ok) return std::unexpected(ok.error());
  Image image(settings.width, settings.height);
  const Tracer tracer(scene, colours, settings);
  const CameraRays rays(scene.camera, settings.width, settings.height);
  const int tiles_x = (settings.width + kTile - 1) / kTile, tiles_y = (settings.height + kTile - 1) / kTile;
  parallel_for(static_cast<std::size_t>(tiles_x * tiles_y), settings.threads, [&](std::size_t tile) {
    const int x0 = static_cast<int>(tile) % tiles_x * kTile, y0 = static_cast<int>(tile) / tiles_x * kTile;
    for (int y = y0; y < std::min(y0 + kTile, settings.height); ++y)
      for (int x = x0; x < std::min(x0 + kTile, settings.width); ++x)
        image.at(x, y) = shade_pixel(tracer, rays, settings, x, y);
  });
  return image;
}

}  // namespace skinspec::render
