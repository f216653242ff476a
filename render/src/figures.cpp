#include "skinspec/render/figures.hpp"

#include <fmt/format.h>

namespace skinspec::render {

std::expected<Image, std::string> render_skin(const SkinOptics& optics, const Colorimetry& colorimetry,
                                              const Skin& skin, const PigmentScales& scales, const Spectrum& illuminant,
                                              const Scene& scene, const RenderSettings& settings) {
  if (optics.model() != skin.model)
    return std::unexpected(fmt::format("a skin of the {} model cannot be rendered with the {} model's optics",
                                       to_string(skin.model), to_string(optics.model())));
  const auto params = scaled_params(skin.model, skin.params, scales);
  if (!params) return std::unexpected(params.error());
  const Spectrum reflectance = skin_reflectance_spectrum(optics, skin.site, *params);
  return render(scene, spectral_colours(colorimetry, reflectance, illuminant), settings);
}

namespace {

struct Cell {
  std::string label;
  std::string illuminant;
  PigmentScales scales;
};

std::expected<Image, std::string> sheet(const SkinOptics& optics, const Colorimetry& colorimetry, const Skin& skin,
                                        const Scene& scene, const RenderSettings& settings, std::string_view title,
                                        const std::vector<Cell>& cells, int columns) {
  std::vector<LabelledImage> images;
  for (const Cell& c : cells) {
    const auto illuminant = colorimetry.illuminant(c.illuminant);
    if (!illuminant) return std::unexpected(illuminant.error());
    auto image = render_skin(optics, colorimetry, skin, c.scales, *illuminant, scene, settings);
    if (!image) return std::unexpected(image.error());
    images.push_back({c.label, std::move(*image)});
  }
  return contact_sheet(title, images, columns);
}

std::vector<Cell> melanin_against_haemoglobin() {
  std::vector<Cell> cells;
  for (const double melanin : {1.0, 2.0, 4.0})
    for (const double blood : {1.0, 2.0, 4.0})
      cells.push_back({fmt::format("MELANIN X{} HB X{}", melanin, blood), "D65", {melanin, blood, blood, 1.0}});
  return cells;
}

}  // namespace

std::expected<std::vector<Figure>, std::string> paper_figures(const SkinOptics& optics, const Colorimetry& colorimetry,
                                                              const Skin& skin, const Scene& scene,
                                                              const RenderSettings& cell) {
  const std::string site = skin.site.name;
  struct Plan {
    std::string file_name, title;
    std::vector<Cell> cells;
    int columns;
  };
  const std::vector<Plan> plans = {
      {"figure4_illuminants.png",
       "FIGURE 4: " + site + " UNDER CIE D65 AND A",
       {{"CIE D65", "D65", {}}, {"CIE A", "A", {}}},
       2},
      {"figure5_melanin_haemoglobin.png", "FIGURE 5: MELANIN AGAINST HAEMOGLOBIN, D65", melanin_against_haemoglobin(),
       3},
      {"figure6_bilirubin.png",
       "FIGURE 6: BILIRUBIN, D65",
       {{"BILIRUBIN X1", "D65", {}}, {"BILIRUBIN X5", "D65", {1, 1, 1, 5}}, {"BILIRUBIN X10", "D65", {1, 1, 1, 10}}},
       3},
  };
  std::vector<Figure> figures;
  for (const Plan& plan : plans) {
    auto image = sheet(optics, colorimetry, skin, scene, cell, plan.title, plan.cells, plan.columns);
    if (!image) return std::unexpected(image.error());
    figures.push_back({plan.file_name, std::move(*image)});
  }
  return figures;
}

}  // namespace skinspec::render
