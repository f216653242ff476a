#pragma once
// A skin rendered in one call, and the seed paper's figures 4-6 as labelled contact sheets.

#include <expected>
#include <string>
#include <vector>

#include "skinspec/render/renderer.hpp"

namespace skinspec::render {

// A skin as a fit describes it: its site (layer thicknesses) and its model's parameters.
struct Skin {
  Site site;
  Params params;
  ModelKind model = ModelKind::paper;
};

// Eq. 2-6 for `skin` with its pigments scaled, under `illuminant`, in `scene`; `optics` must
// be those of the skin's model.
std::expected<Image, std::string> render_skin(const SkinOptics& optics, const Colorimetry& colorimetry,
                                              const Skin& skin, const PigmentScales& scales, const Spectrum& illuminant,
                                              const Scene& scene, const RenderSettings& settings);

struct Figure {
  std::string file_name;  // "figure4_illuminants.png", ...
  Image image;
};

// Figure 4: the skin under CIE D65 and A. Figure 5: melanin x1, x2, x4 (rows) against
// haemoglobin, oxy and deoxy together, x1, x2, x4 (columns). Figure 6: bilirubin x1, x5, x10.
// Each cell is `cell` as a render of `scene`; figures 5 and 6 are lit by D65.
std::expected<std::vector<Figure>, std::string> paper_figures(const SkinOptics& optics, const Colorimetry& colorimetry,
                                                              const Skin& skin, const Scene& scene,
                                                              const RenderSettings& cell);

}  // namespace skinspec::render
