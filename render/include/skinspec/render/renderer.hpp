#pragma once
// The ray tracer: one camera ray per sub-pixel, the nearest triangle through the BVH, a shadow
// ray to each light, eq. 2 for each unshadowed light, eq. 6 through SpectralColours, and XYZ
// to linear sRGB with no chromatic adaptation (docs/render.md says why).

#include <expected>
#include <optional>
#include <string_view>
#include <utility>
#include <string>
#include <vector>

#include "skinspec/render/image.hpp"
#include "skinspec/render/mesh.hpp"
#include "skinspec/render/skin_colour.hpp"
#include "skinspec/render/torrance_sparrow.hpp"

namespace skinspec::render {

struct Light {
  enum class Kind { directional, point };
  Kind kind = Kind::directional;
  Vec3 vector;             // directional: towards the light; point: its position
  double intensity = 1.0;  // directional: irradiance; point: irradiance at distance 1
};

struct Camera {
  Vec3 position{0, 0, 10};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  double vertical_fov_degrees = 35;
};

struct Scene {
  Mesh mesh;  // with vertex normals
  Camera camera;
  std::vector<Light> lights;
};

struct RenderSettings {
  int width = 512, height = 512;
  SurfaceParams surface;
  // XYZ multiplier before sRGB: 1 shows a white diffuser facing a light of intensity 1 as
  // sRGB white (1, 1, 1) under D65.
  double exposure = 1;
  int samples_per_side = 1;  // supersampling: n x n rays per pixel
  bool shadows = true;
  unsigned threads = 0;                  // 0: one per core
  Rgb background{0.02f, 0.02f, 0.025f};  // linear sRGB
};

inline constexpr int kMaxImageSide = 4096;
inline constexpr int kMaxSamplesPerSide = 8;

// An error for sizes outside 1..kMaxImageSide, bad surface parameters, or lights that are not
// finite; otherwise the image in linear sRGB (values may exceed 1 in highlights).
std::expected<Image, std::string> render(const Scene& scene, const SpectralColours& colours,
                                         const RenderSettings& settings);

// "WxH" (such as "512x512") with each side 1..max_side; nothing for anything else.
std::optional<std::pair<int, int>> parse_image_size(std::string_view text, int max_side = kMaxImageSide);

// Checks a surface's parameters: alpha, beta >= 0, roughness in (0, pi/2], index in (1, 5].
std::expected<void, std::string> check_surface(const SurfaceParams& surface);

}  // namespace skinspec::render
