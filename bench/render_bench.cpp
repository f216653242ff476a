// Rendering the procedural hand at 512 x 512 with shadows from both lights on 2 threads.
// Goal: <= 1 s per image with one ray per pixel. Run: build/release/bin/render_bench

#include <benchmark/benchmark.h>

#include "fitter_loader.hpp"
#include "skinspec/render/figures.hpp"
#include "skinspec/render/scenes.hpp"

namespace {

using namespace skinspec;

void BM_RenderHand512(benchmark::State& state) {
  const auto fitter = load_fitter();
  if (!fitter) {
    state.SkipWithError(fitter.error().c_str());
    return;
  }
  // The paper model at the README demo's forearm values.
  const render::Skin skin{*fitter->optics(ModelKind::paper).site("forearm"), {0.04, 5, 6, 3, 1}, ModelKind::paper};
  const Spectrum d65 = *fitter->colorimetry().illuminant("D65");
  const render::Scene scene = render::builtin_scene(render::SceneKind::hand, 1.0);
  render::RenderSettings settings;
  settings.width = settings.height = 512;
  settings.threads = 2;
  settings.samples_per_side = static_cast<int>(state.range(0));
  for (auto _ : state) {
    auto image =
        render::render_skin(fitter->optics(ModelKind::paper), fitter->colorimetry(), skin, {}, d65, scene, settings);
    benchmark::DoNotOptimize(image);
  }
  state.counters["triangles"] = static_cast<double>(scene.mesh.triangles.size());
}
BENCHMARK(BM_RenderHand512)->ArgName("samples_per_side")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Generating the hand's mesh (capsules and vertex normals), done once per command.
void BM_BuildHand(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(render::procedural_hand());
}
BENCHMARK(BM_BuildHand)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
