#include "skinspec/maps/mapper.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numeric>

#include "skinspec/spectral/parallel.hpp"

namespace skinspec::maps {

namespace {

constexpr float kNotDetermined = std::numeric_limits<float>::quiet_NaN();

// Skins the spectral-angle test compares a pixel with: the model's light, medium and dark
// skin (melanin 2, 10, 40 and 80; everything else at its default).
constexpr double kReferenceMelanin[] = {2, 10, 40, 80};

std::vector<double> unit_length(std::vector<double> v) {
  const double norm = std::sqrt(std::inner_product(v.begin(), v.end(), v.begin(), 0.0));
  for (double& x : v) x /= norm;
  return v;
}

// A neighbour's start that ends with an RMSE above this many times the neighbour's, plus
// kRestartSlack, is fitted again from the coarse search: the two pixels differ too much for the
// one answer to lead to the other's.
constexpr double kRestartRatio = 1.5, kRestartSlack = 0.001;

}  // namespace

std::string_view to_string(MaskReason reason) {
  switch (reason) {
    case MaskReason::skin:
      return "skin";
    case MaskReason::no_data:
      return "no_data";
    case MaskReason::saturated:
      return "saturated";
    case MaskReason::too_dark:
      return "too_dark";
    case MaskReason::not_skin:
      return "not_skin";
    case MaskReason::not_fitted:
      return "not_fitted";
  }
  return "not_fitted";
}

std::expected<void, CubeError> check_coverage(const CubeInfo& cube) {
  const auto inside = [](double nm) { return nm >= SkinOptics::kFirstNm && nm <= SkinOptics::kLastNm; };
  const auto first = std::ranges::find_if(cube.wavelength_nm, inside);
  const auto last = std::ranges::find_if(cube.wavelength_nm.rbegin(), cube.wavelength_nm.rend(), inside);
  if (first == cube.wavelength_nm.end() || *first > kMinCoverFromNm || *last < kMinCoverToNm)
    return std::unexpected(
        CubeError{cube.file, "wavelength",
                  cube.wavelength_nm.empty()
                      ? "no bands"
                      : fmt::format("the bands span {}-{} nm; a fit needs {}-{} nm inside the model's {}-{} nm",
                                    cube.wavelength_nm.front(), cube.wavelength_nm.back(), kMinCoverFromNm,
                                    kMinCoverToNm, SkinOptics::kFirstNm, SkinOptics::kLastNm)});
  return {};
}

std::vector<MapBand> map_bands(ModelKind model) {
  std::vector<MapBand> bands;
  for (const ParamSpec& p : model_spec(model).params) {
    bands.push_back({std::string(p.name), std::string(p.unit)});
    bands.push_back({std::string(p.name) + "_stderr", std::string(p.unit)});
  }
  bands.push_back({"rmse", std::string(kRmseUnit)});
  bands.push_back({"delta_e00_d65", std::string(kDeltaE00Unit)});
  bands.push_back({"iterations", "solver steps"});
  std::string terminations = "number:", reasons = "number:";
  for (const auto& [termination, name] : termination_names())
    terminations += fmt::format(" {} {}", static_cast<int>(termination), name);
  for (const MaskReason reason : kMaskReasons)
    reasons += fmt::format(" {} {}", static_cast<int>(reason), to_string(reason));
  bands.push_back({"termination", terminations});
  bands.push_back({"mask", reasons});
  return bands;
}

void MapTally::add(const MapTally& other) {
  for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] += other.pixels[i];
  iterations += other.iterations;
  started_from_neighbour += other.started_from_neighbour;
  restarted += other.restarted;
}

std::expected<std::vector<double>, CubeError> mean_spectrum(const Cube& cube, Region region) {
  const CubeInfo& info = cube.info();
  if (region.w == 0 || region.h == 0) region = {0, 0, info.samples, info.lines};
  if (region.x + region.w > info.samples || region.y + region.h > info.lines)
    return std::unexpected(CubeError{info.file, "",
                                     fmt::format("the region {},{},{},{} is not inside its {} × {} pixels", region.x,
                                                 region.y, region.w, region.h, info.samples, info.lines)});
  std::vector<double> sum(info.bands, 0.0);
  std::vector<float> values;  // each block read into the last one's memory
  constexpr std::size_t kBlock = 32;
  for (std::size_t first = region.y; first < region.y + region.h; first += kBlock) {
    const std::size_t count = std::min(kBlock, region.y + region.h - first);
    if (auto read = cube.read_lines(first, count, values); !read) return std::unexpected(read.error());
    for (std::size_t l = 0; l < count; ++l)
      for (std::size_t s = region.x; s < region.x + region.w; ++s)
        for (std::size_t b = 0; b < info.bands; ++b) {
          const auto v = static_cast<double>(values[(l * info.samples + s) * info.bands + b]);
          if (!std::isfinite(v) || (info.ignore_value && v == *info.ignore_value) ||
              (info.type_maximum && v == *info.type_maximum))
            return std::unexpected(CubeError{
                info.file, "",
                fmt::format("pixel {},{} at {} nm is missing or saturated", s, first + l, info.wavelength_nm[b])});
          sum[b] += v;
        }
  }
  for (double& v : sum) v /= static_cast<double>(region.w * region.h);
  return sum;
}

std::expected<std::vector<double>, CubeError> panel_spectrum(const Cube& panel, const CubeInfo& mapped) {
  if (panel.info().wavelength_nm != mapped.wavelength_nm)
    return std::unexpected(CubeError{panel.info().file, "wavelength", fmt::format("not the bands of {}", mapped.file)});
  return mean_spectrum(panel);
}

std::expected<Radiometry, CubeError> radiometry(const CubeInfo& cube, const std::vector<double>& white,
                                                const std::vector<double>& white_reflectance,
                                                const std::vector<double>& dark) {
  Radiometry r{dark.empty() ? std::vector<double>(cube.bands, 0.0) : dark, std::vector<double>(cube.bands)};
  if (white.size() != cube.bands || white_reflectance.size() != cube.bands || r.dark.size() != cube.bands)
    return std::unexpected(
        CubeError{cube.file, "bands", "the white, its reflectance and the dark need one value a band"});
  for (std::size_t b = 0; b < cube.bands; ++b) {
    if (!(white[b] > r.dark[b]))
      return std::unexpected(CubeError{cube.file, "white",
                                       fmt::format("at {} nm the white ({}) is not above the dark ({})",
                                                   cube.wavelength_nm[b], white[b], r.dark[b])});
    r.gain[b] = white_reflectance[b] / (white[b] - r.dark[b]);
  }
  return r;
}

Mapper::Mapper(const Fitter& fitter, MapOptions options, const CubeInfo& cube)
    : fitter_(fitter), options_(std::move(options)), cube_(cube), band_count_(map_bands(options_.fit.model).size()) {
  for (std::size_t b = 0; b < cube_.bands; ++b) {
    const double nm = cube_.wavelength_nm[b];
    if (nm >= SkinOptics::kFirstNm && nm <= SkinOptics::kLastNm) fitted_bands_.push_back(b), fitted_nm_.push_back(nm);
    if (nm >= kMinCoverFromNm && nm <= kMinCoverToNm) visible_bands_.push_back(b);
  }
  const SkinOptics& optics = fitter_.optics(options_.fit.model);
  const auto site = optics.site(options_.fit.site);
  if (!site || fitted_nm_.size() < 2) return;
  const SkinModel model(optics, *site, fitted_nm_, options_.fit.lateral_diffusion);
  static_assert(std::size(kReferenceMelanin) == kReferenceSkins);
  references_.resize(fitted_nm_.size());
  for (std::size_t k = 0; k < kReferenceSkins; ++k) {
    Params p = default_params(options_.fit.model);
    p[kMelanin] = kReferenceMelanin[k];
    std::vector<double> r(fitted_nm_.size());
    for (std::size_t i = 0; i < r.size(); ++i) r[i] = model.reflectance_at(i, p.data());
    r = unit_length(std::move(r));
    for (std::size_t i = 0; i < r.size(); ++i) references_[i][k] = r[i];
  }
}

MaskReason Mapper::judge(std::span<const double> reflectance, bool clipped) const {
  for (const double r : reflectance)
    if (!std::isfinite(r)) return MaskReason::no_data;
  if (clipped || std::ranges::any_of(reflectance, [](double r) { return r > 1; })) return MaskReason::saturated;
  double visible = 0;
  for (const std::size_t b : visible_bands_) visible += reflectance[b];
  if (visible_bands_.empty() || visible / static_cast<double>(visible_bands_.size()) < options_.min_mean_reflectance)
    return MaskReason::too_dark;
  // The smallest angle is the largest cosine: the dot product with each unit reference over
  // the pixel's length. The pixel's squared length and its dot products are summed side by side
  // in one pass, each in the bands' order: one sum after another waited on each addition, and
  // judging took 2 % of a pixel's time.
  double squares = 0;
  std::array<double, kReferenceSkins> dots{};
  for (std::size_t i = 0; i < references_.size(); ++i) {
    const double r = reflectance[fitted_bands_[i]];
    squares += r * r;
    for (std::size_t k = 0; k < kReferenceSkins; ++k) dots[k] += r * references_[i][k];
  }
  double cosine = -1;
  for (const double dot : dots) cosine = std::max(cosine, dot / std::sqrt(squares));
  const double angle =
      references_.empty() ? std::numeric_limits<double>::infinity() : std::acos(std::clamp(cosine, -1.0, 1.0));
  return angle > options_.max_spectral_angle ? MaskReason::not_skin : MaskReason::skin;
}

double Mapper::reflectance_of(double stored, std::size_t band) const {
  if (cube_.ignore_value && stored == *cube_.ignore_value) return std::numeric_limits<double>::quiet_NaN();
  if (options_.radiance) return (stored - options_.radiance->dark[band]) * options_.radiance->gain[band];
  // Most cubes hold reflectance itself: no division for each of a pixel's bands.
  return cube_.reflectance_scale == 1 ? stored : stored / cube_.reflectance_scale;
}

std::vector<float> Mapper::reflectance_lines(std::span<const float> values) const {
  std::vector<float> out(values.size());
  for (std::size_t i = 0; i < values.size(); ++i)
    out[i] = static_cast<float>(reflectance_of(static_cast<double>(values[i]), i % cube_.bands));
  return out;
}

void Mapper::map_line(std::span<const float> line, std::span<float> out, MapTally& tally) const {
  // The last fitted pixel's answer and RMSE, while its right neighbour is skin.
  struct Neighbour {
    Params params;
    double rmse;
  };
  std::optional<Neighbour> left;
  std::vector<double> reflectance(cube_.bands);
  for (std::size_t s = 0; s < cube_.samples; ++s) {
    const std::span<const float> stored = line.subspan(s * cube_.bands, cube_.bands);
    const std::span<float> answer = out.subspan(s * band_count_, band_count_);
    std::ranges::fill(answer, kNotDetermined);
    bool clipped = false;
    for (std::size_t b = 0; b < cube_.bands; ++b) {
      const auto v = static_cast<double>(stored[b]);
      reflectance[b] = reflectance_of(v, b);
      clipped = clipped || (cube_.type_maximum && v == *cube_.type_maximum);
    }
    MaskReason reason = judge(reflectance, clipped);
    std::optional<FitResult> fit;
    if (reason == MaskReason::skin) {
      const Spectrum spectrum = *Spectrum::create(cube_.wavelength_nm, reflectance);  // finite, increasing
      FitOptions options = options_.fit;
      if (options_.neighbour_starts && left) {
        options.start = left->params;
        auto started = fitter_.fit(spectrum, options);
        ++tally.started_from_neighbour;
        if (started && started->converged && started->rmse <= kRestartRatio * left->rmse + kRestartSlack)
          fit = std::move(*started);
        else ++tally.restarted;
        options.start.reset();
      }
      if (!fit) {
        auto searched = fitter_.fit(spectrum, options);
        if (searched) fit = std::move(*searched);
        else reason = MaskReason::not_fitted;
      }
    }
    ++tally.pixels[static_cast<std::size_t>(reason)];
    answer[band_count_ - 1] = static_cast<float>(reason);
    left.reset();
    if (!fit) continue;
    left = Neighbour{fit->params, fit->rmse};
    tally.iterations += static_cast<std::size_t>(fit->iterations);
    for (std::size_t p = 0; p < fit->params.size(); ++p)
      if (fit->determination[p].determined()) {
        answer[2 * p] = static_cast<float>(fit->params[p]);
        answer[2 * p + 1] = static_cast<float>(fit->standard_error[p]);
      }
    const std::size_t figures = 2 * fit->params.size();
    answer[figures] = static_cast<float>(fit->rmse);
    answer[figures + 1] = static_cast<float>(fit->delta_e00_d65);
    answer[figures + 2] = static_cast<float>(fit->iterations);
    answer[figures + 3] = static_cast<float>(fit->termination ? static_cast<int>(*fit->termination) : -1);
  }
}

std::vector<float> Mapper::map_lines(std::span<const float> values, std::size_t lines, MapTally& tally) const {
  std::vector<float> out(lines * cube_.samples * band_count_);
  std::vector<MapTally> tallies(lines);
  const std::size_t stored = cube_.samples * cube_.bands, answered = cube_.samples * band_count_;
  parallel_for(lines, options_.threads, [&](std::size_t l) {
    map_line(values.subspan(l * stored, stored), std::span(out).subspan(l * answered, answered), tallies[l]);
  });
  for (const MapTally& t : tallies) tally.add(t);
  return out;
}

}  // namespace skinspec::maps
