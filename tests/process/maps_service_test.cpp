// Skin maps through a real skinspecd (POST /api/v1/maps): a cube named in --data-dir and the
// same cube uploaded give the answers `skinspec map` writes, byte for byte; paths leading out of
// the data directory are forbidden; bad cubes are refused with a 4xx naming the file and field;
// a map cancelled, or its daemon killed, leaves no map and no file behind.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <thread>

#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "support/envi_cube.hpp"

namespace skinspec::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace skinspec::client;
using ::testing::HasSubstr;
using namespace std::chrono_literals;

class MapsServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(data_);
    fs::create_directories(work_);
    rig_ = std::make_unique<AcquisitionRig>(
        rig_options(dir_.path().string(), {"--time-scale", "0"},
                    {"--data-dir", data_.string(), "--work-dir", work_.string(), "--log-level", "warn"}));
    ASSERT_TRUE(rig_->ready()) << rig_->logs();
  }
  unsigned short port() const { return rig_->port; }
  HttpReply post_path(const json& body) const { return http_request(port(), "POST", "/api/v1/maps", body.dump()); }
  HttpReply post_upload(const std::string& bytes, const std::string& query) const {
    return http_request(port(), "POST", "/api/v1/maps?" + query, bytes, {{"Content-Type", "application/octet-stream"}});
  }
  // A tar archive of the ENVI cube STEM.hdr and STEM.img in `dir`.
  std::string tar_of(const fs::path& dir, const std::string& stem) const {
    const fs::path archive = dir_.path() / (stem + ".tar");
    const auto made =
        run_process("/usr/bin/tar", {"cf", archive.string(), "-C", dir.string(), stem + ".hdr", stem + ".img"});
    EXPECT_EQ(made.exit_status, 0) << made.describe();
    return file_bytes(archive.string());
  }
  // What `skinspec map` writes for a cube, in DIR/reference.
  fs::path reference_map(const fs::path& header) const {
    const fs::path out = dir_.path() / "reference";
    const auto run = run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", {"map", header.string(), "-o", out.string()});
    EXPECT_EQ(run.exit_status, 0) << run.describe();
    return out;
  }
  json finished(const HttpReply& accepted) const {
    EXPECT_EQ(accepted.status, 202) << accepted.body;
    return wait_for_job(port(), accepted.json(), 120s);
  }
  // The scratch directories map jobs left in the work directory.
  std::vector<std::string> scratch_left() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(work_)) names.push_back(entry.path().filename().string());
    return names;
  }
  // Waits until a map job is fitting pixels; the job as it then is.
  json fitting(const json& accepted) const {
    const std::string target = "/api/v1/jobs/" + std::to_string(accepted["job_id"].get<long long>());
    json job;
    for (int i = 0; i < 600; ++i) {
      job = get_json(port(), target);
      if (job["progress"].value("phase", "") == "fitting" && job["progress"].value("spectra_done", 0) > 0) break;
      std::this_thread::sleep_for(20ms);
    }
    return job;
  }

  ScratchDirectory dir_;
  fs::path data_ = dir_.path() / "data";
  fs::path work_ = dir_.path() / "work";
  std::unique_ptr<AcquisitionRig> rig_;
};

TEST_F(MapsServiceTest, ACubeNamedInTheDataDirAndTheSameCubeUploadedMapAsTheCommandLineMapsThem) {
  const auto header = write_envi(data_ / "face", skin_cube(6, 5), {});
  const fs::path reference = reference_map(header);
  const long long session = new_session(port(), "map-subject");
  ASSERT_GT(session, 0);

  const json by_path = finished(post_path({{"path", "face.hdr"}, {"session_id", session}}));
  ASSERT_EQ(by_path["state"], "succeeded") << by_path.dump(2);
  const json by_upload = finished(post_upload(tar_of(data_, "face"), "name=face-upload"));
  ASSERT_EQ(by_upload["state"], "succeeded") << by_upload.dump(2);

  for (const json& job : {by_path, by_upload}) {
    const auto id = job["result"]["map_id"].get<long long>();
    const json map = get_json(port(), fmt::format("/api/v1/maps/{}", id));
    EXPECT_EQ(map["summary"]["pixels"]["skin"], 30) << map.dump(2);
    EXPECT_EQ(map["summary"]["lines"], 6);
    EXPECT_EQ(map["bands"].size(), 19u);
    const auto cube = http_request(port(), "GET", map["links"]["cube"].get<std::string>());
    ASSERT_EQ(cube.status, 200);
    EXPECT_EQ(cube.body, file_bytes((reference / "face.map.img").string())) << "the answers differ from skinspec map's";
    // The same header but for its description, which names the cube as it was asked for.
    const auto described = [](std::string text) {
      const auto from = text.find("description = {"), to = text.find('}', from);
      const std::string description = text.substr(from, to + 1 - from);
      return std::pair{text.erase(from, to + 1 - from), description};
    };
    const auto [served, description] =
        described(http_request(port(), "GET", map["links"]["header"].get<std::string>()).body);
    EXPECT_EQ(served, described(file_bytes((reference / "face.map.hdr").string())).first);
    EXPECT_THAT(description, HasSubstr(job == by_path ? "of face.hdr}" : "of face-upload}"));
    const auto png = http_request(port(), "GET", map["links"]["pictures"]["melanin"].get<std::string>());
    ASSERT_EQ(png.status, 200);
    EXPECT_EQ(png.header("content-type"), "image/png");
    EXPECT_EQ(png.body, file_bytes((reference / "face.melanin.png").string()));
    // Stored maps never change: a client holding one is told so without the data.
    const auto again = http_request(port(), "GET", map["links"]["cube"].get<std::string>(), "",
                                    {{"If-None-Match", cube.header("etag")}});
    EXPECT_EQ(again.status, 304);
    EXPECT_TRUE(again.body.empty());
  }
  const json of_session = get_json(port(), fmt::format("/api/v1/maps?session_id={}", session));
  ASSERT_EQ(of_session["maps"].size(), 1u) << of_session.dump(2);
  EXPECT_EQ(of_session["maps"][0]["name"], "face");
  EXPECT_EQ(get_json(port(), "/api/v1/maps")["maps"].size(), 2u);
  EXPECT_THAT(scratch_left(), ::testing::IsEmpty());
}

TEST_F(MapsServiceTest, AnHdf5CubeUploadedMapsAsItsEnviCube) {
  const auto cube = skin_cube(4, 6);
  const auto header = write_envi(data_ / "here", cube, {});
  const fs::path reference = reference_map(header);
  const std::string script =
      "import numpy, sys, h5py\n"
      "bil = numpy.fromfile(sys.argv[1], dtype='<f4').reshape(" +
      fmt::format("{}, {}, {}", cube.lines, cube.bands, cube.samples) +
      ")\n"
      "with h5py.File(sys.argv[2], 'w') as f:\n"
      "    f['cube'] = bil.transpose(0, 2, 1)\n"
      "    f['wavelength'] = numpy.array([float(w) for w in sys.argv[3].split(',')])\n";
  std::string wavelengths;
  for (const double w : cube.wavelength_nm) wavelengths += (wavelengths.empty() ? "" : ",") + std::to_string(w);
  const fs::path h5 = dir_.path() / "here.h5";
  const auto made =
      run_process("/usr/bin/python3", {"-c", script, (data_ / "here.img").string(), h5.string(), wavelengths});
  ASSERT_EQ(made.exit_status, 0) << made.describe();
  const json job = finished(post_upload(file_bytes(h5.string()), "name=here.h5"));
  ASSERT_EQ(job["state"], "succeeded") << job.dump(2);
  const auto map = get_json(port(), fmt::format("/api/v1/maps/{}", job["result"]["map_id"].get<long long>()));
  EXPECT_EQ(map["name"], "here.h5");
  EXPECT_EQ(http_request(port(), "GET", map["links"]["cube"].get<std::string>()).body,
            file_bytes((reference / "here.map.img").string()));
}

// The cube's answer bands as floats.
std::vector<float> floats_of(const std::string& bytes) {
  std::vector<float> out(bytes.size() / sizeof(float));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(float));
  return out;
}

TEST_F(MapsServiceTest, ARadianceCubeWithAWhiteCubeAndADarkCubeMapsAsItsReflectance) {
  // The light rises towards the red; the dark is a constant offset; the white panel's own cube
  // has a reflectance of 0.99.
  const CubeValues reflectance = skin_cube(4, 5);
  CubeValues radiance = reflectance, white{2, 3, reflectance.bands, reflectance.wavelength_nm, {}},
             dark{2, 2, reflectance.bands, reflectance.wavelength_nm, {}};
  constexpr double kDark = 40;
  const auto light = [&](std::size_t b) { return 500 + 2 * reflectance.wavelength_nm[b]; };
  for (std::size_t i = 0; i < radiance.values.size(); ++i)
    radiance.values[i] = reflectance.values[i] * light(i % radiance.bands) + kDark;
  for (std::size_t i = 0; i < 2 * 3 * white.bands; ++i) white.values.push_back(0.99 * light(i % white.bands) + kDark);
  dark.values.assign(2 * 2 * dark.bands, kDark);
  write_envi(data_ / "reflectance", reflectance, {});
  write_envi(data_ / "radiance", radiance, {});
  write_envi(data_ / "white", white, {});
  write_envi(data_ / "dark", dark, {});
  const auto cube_of = [&](const json& job) {
    return floats_of(
        http_request(port(), "GET", fmt::format("/api/v1/maps/{}/cube", job["result"]["map_id"].get<long long>()))
            .body);
  };
  const json expected_job = finished(post_path({{"path", "reflectance.hdr"}}));
  const json got_job = finished(
      post_path({{"path", "radiance.hdr"}, {"white", "white.hdr"}, {"dark", "dark.hdr"}, {"white_reflectance", 0.99}}));
  ASSERT_EQ(got_job["state"], "succeeded") << got_job.dump(2);
  const auto expected = cube_of(expected_job), got = cube_of(got_job);
  ASSERT_EQ(got.size(), expected.size());
  ASSERT_FALSE(got.empty());
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (std::isnan(expected[i])) EXPECT_TRUE(std::isnan(got[i])) << i;
    else EXPECT_NEAR(got[i], expected[i], 1e-3 * std::abs(static_cast<double>(expected[i])) + 1e-6) << i;
  }
  // A dark without a white, a white of other bands, and a white outside the data directory.
  EXPECT_EQ(post_path({{"path", "radiance.hdr"}, {"dark", "dark.hdr"}}).status, 422);
  write_envi(data_ / "narrow", CubeValues{1, 1, 2, {500, 600}, {0.5, 0.5}}, {});
  const auto other_bands = post_path({{"path", "radiance.hdr"}, {"white", "narrow.hdr"}});
  EXPECT_EQ(other_bands.status, 422) << other_bands.body;
  EXPECT_THAT(other_bands.json()["error"].value("message", ""), HasSubstr("narrow.hdr: wavelength"));
  EXPECT_EQ(post_path({{"path", "radiance.hdr"}, {"white", "../white.hdr"}}).status, 403);
}

TEST_F(MapsServiceTest, PathsLeadingOutOfTheDataDirectoryAreForbidden) {
  const fs::path outside = dir_.path() / "outside";
  fs::create_directories(outside);
  write_envi(outside / "secret", skin_cube(2, 2), {});
  // Inside by name, outside once links are followed: a linked directory, a linked header, and a
  // header inside whose data file is a link to one outside.
  fs::create_directory_symlink(outside, data_ / "linked-dir");
  fs::create_symlink(outside / "secret.hdr", data_ / "linked.hdr");
  fs::copy_file(outside / "secret.hdr", data_ / "half.hdr");
  fs::create_symlink(outside / "secret.img", data_ / "half.img");
  for (const std::string& path :
       std::vector<std::string>{"../outside/secret.hdr", (outside / "secret.hdr").string(), "linked-dir/secret.hdr",
                                "linked.hdr", "half.hdr", "sub/../../outside/secret.hdr"}) {
    const auto reply = post_path({{"path", path}});
    EXPECT_EQ(reply.status, 403) << path << ": " << reply.body;
    EXPECT_EQ(reply.json()["error"]["code"], "outside_data_dir") << path << ": " << reply.body;
  }
  EXPECT_THAT(get_json(port(), "/api/v1/maps")["maps"], ::testing::IsEmpty());
  EXPECT_THAT(scratch_left(), ::testing::IsEmpty());
}

// An upload whose values would be another file the daemon can read (its database, its token
// file, its TLS key): a GDAL VRT naming a raw file, and HDF5 files with an external dataset, a
// virtual dataset and a link into another file. Each is refused, and nothing is read or stored.
TEST_F(MapsServiceTest, AnUploadWhoseValuesAreInOtherFilesIsRefused) {
  const fs::path outside = dir_.path() / "outside";
  fs::create_directories(outside);
  const auto cube = skin_cube(2, 3);
  write_envi(outside / "secret", cube, {});
  const std::string script =
      "import numpy, sys, h5py\n"
      "outside, wl = sys.argv[1], numpy.array([float(w) for w in sys.argv[2].split(',')])\n"
      "shape = (" +
      fmt::format("{}, {}, {}", cube.lines, cube.samples, cube.bands) +
      ")\n"
      "with h5py.File(outside + '/secret.h5', 'w') as f:\n"
      "    f['cube'] = numpy.zeros(shape, dtype='<f4')\n"
      "with h5py.File(outside + '/external.h5', 'w') as f:\n"
      "    f.create_dataset('cube', shape=shape, dtype='<f4',\n"
      "                     external=[(outside + '/secret.img', 0, 4 * int(numpy.prod(shape)))])\n"
      "    f['wavelength'] = wl\n"
      "layout = h5py.VirtualLayout(shape=shape, dtype='<f4')\n"
      "layout[:] = h5py.VirtualSource(outside + '/secret.h5', 'cube', shape=shape)\n"
      "with h5py.File(outside + '/virtual.h5', 'w') as f:\n"
      "    f.create_virtual_dataset('cube', layout)\n"
      "    f['wavelength'] = wl\n"
      "with h5py.File(outside + '/linked.h5', 'w') as f:\n"
      "    f['cube'] = h5py.ExternalLink(outside + '/secret.h5', '/cube')\n"
      "    f['wavelength'] = wl\n";
  std::string wavelengths;
  for (const double w : cube.wavelength_nm) wavelengths += (wavelengths.empty() ? "" : ",") + std::to_string(w);
  const auto made = run_process("/usr/bin/python3", {"-c", script, outside.string(), wavelengths});
  ASSERT_EQ(made.exit_status, 0) << made.describe();
  const std::string vrt = raw_file_vrt(outside / "secret.img", cube.lines, cube.samples, cube.wavelength_nm);
  const std::vector<std::pair<std::string, std::string>> uploads{
      {"cube.vrt", vrt},
      {"cube.tif", vrt},
      {"external.h5", file_bytes((outside / "external.h5").string())},
      {"virtual.h5", file_bytes((outside / "virtual.h5").string())},
      {"linked.h5", file_bytes((outside / "linked.h5").string())}};
  for (const auto& [name, bytes] : uploads) {
    const auto reply = post_upload(bytes, "name=" + name);
    EXPECT_EQ(reply.status, 422) << name << ": " << reply.body;
    EXPECT_EQ(reply.json()["error"]["code"], "bad_cube") << name << ": " << reply.body;
  }
  EXPECT_THAT(get_json(port(), "/api/v1/maps")["maps"], ::testing::IsEmpty());
  EXPECT_THAT(scratch_left(), ::testing::IsEmpty());
}

TEST_F(MapsServiceTest, BadCubesAreRefusedWithA4xxNamingTheFileAndTheField) {
  for (const auto& c : write_bad_cubes(data_)) {
    const auto by_path = post_path({{"path", c.name + ".hdr"}});
    EXPECT_EQ(by_path.status, 422) << c.name << ": " << by_path.body;
    EXPECT_EQ(by_path.json()["error"]["code"], "bad_cube") << c.name;
    EXPECT_THAT(by_path.json()["error"].value("message", ""), HasSubstr(c.name + ".hdr: " + c.field)) << c.name;
    const auto uploaded = post_upload(tar_of(data_, c.name), "name=" + c.name + ".tar");
    EXPECT_EQ(uploaded.status, 422) << c.name << ": " << uploaded.body;
    EXPECT_THAT(uploaded.json()["error"].value("message", ""), HasSubstr(c.field)) << c.name << ": " << uploaded.body;
  }
  // An archive that would unpack to far more than its size (50 MB of zeros in 50 kB): refused
  // before anything is unpacked.
  const fs::path bomb = dir_.path() / "bomb";
  fs::create_directories(bomb);
  std::ofstream(bomb / "bomb.hdr") << "ENVI\n";
  fs::resize_file(bomb / "bomb.hdr", 50'000'000);
  const auto packed =
      run_process("/usr/bin/tar", {"czf", (bomb / "bomb.tgz").string(), "-C", bomb.string(), "bomb.hdr"});
  ASSERT_EQ(packed.exit_status, 0) << packed.describe();
  const auto refused = post_upload(file_bytes((bomb / "bomb.tgz").string()), "name=bomb.tgz");
  EXPECT_EQ(refused.status, 422) << refused.body;
  EXPECT_THAT(refused.json()["error"].value("message", ""), HasSubstr("more than 20 times the archive"));

  const auto garbage = post_upload(std::string(4096, 'x'), "name=garbage.tif");
  EXPECT_EQ(garbage.status, 422) << garbage.body;
  EXPECT_THAT(garbage.json()["error"].value("message", ""), HasSubstr("garbage.tif"));
  EXPECT_EQ(post_path({{"path", "missing.hdr"}}).status, 422);
  EXPECT_EQ(post_path({{"path", "face.hdr"}, {"surprise", 1}}).status, 422);
  EXPECT_THAT(get_json(port(), "/api/v1/maps")["maps"], ::testing::IsEmpty());
  EXPECT_THAT(scratch_left(), ::testing::IsEmpty());
}

TEST_F(MapsServiceTest, AMapCancelledMidWayStoresNothingAndLeavesNoFile) {
  write_envi(data_ / "large", skin_cube(400, 300), {});
  const auto accepted = post_path({{"path", "large.hdr"}});
  ASSERT_EQ(accepted.status, 202) << accepted.body;
  const json running = fitting(accepted.json());
  ASSERT_EQ(running["progress"]["phase"], "fitting") << running.dump(2);
  EXPECT_THAT(scratch_left(), ::testing::SizeIs(1));
  const auto cancel =
      http_request(port(), "DELETE", "/api/v1/jobs/" + std::to_string(running["job_id"].get<long long>()));
  ASSERT_EQ(cancel.status, 200) << cancel.body;
  const json ended = wait_for_job(port(), accepted.json(), 60s);
  EXPECT_EQ(ended["state"], "cancelled") << ended.dump(2);
  EXPECT_THAT(get_json(port(), "/api/v1/maps")["maps"], ::testing::IsEmpty());
  EXPECT_THAT(scratch_left(), ::testing::IsEmpty());
}

TEST_F(MapsServiceTest, ADaemonKilledMidMapLeavesNoMapAndTheNextOneRemovesItsFiles) {
  write_envi(data_ / "large", skin_cube(400, 300), {});
  const auto accepted = post_upload(tar_of(data_, "large"), "name=large");
  ASSERT_EQ(accepted.status, 202) << accepted.body;
  ASSERT_EQ(fitting(accepted.json())["progress"]["phase"], "fitting");
  rig_->stop_daemon(SIGKILL);
  EXPECT_THAT(scratch_left(), ::testing::SizeIs(1)) << "the killed daemon's upload and answers";
  rig_->restart_daemon();
  ASSERT_NE(port(), 0) << rig_->logs();
  const json job = get_json(port(), "/api/v1/jobs/" + std::to_string(accepted.json()["job_id"].get<long long>()));
  EXPECT_EQ(job["state"], "failed") << job.dump(2);
  EXPECT_EQ(job["error"]["code"], "interrupted");
  EXPECT_THAT(get_json(port(), "/api/v1/maps")["maps"], ::testing::IsEmpty());
  EXPECT_THAT(scratch_left(), ::testing::IsEmpty());
  // And the service maps again.
  write_envi(data_ / "small", skin_cube(2, 3), {});
  EXPECT_EQ(finished(post_path({{"path", "small.hdr"}}))["state"], "succeeded");
}

TEST_F(MapsServiceTest, AStoredMapsMissingPartsAreNotFound) {
  write_envi(data_ / "face", skin_cube(2, 2), {});
  const json job = finished(post_path({{"path", "face.hdr"}}));
  ASSERT_EQ(job["state"], "succeeded") << job.dump(2);
  const auto id = job["result"]["map_id"].get<long long>();
  EXPECT_EQ(http_request(port(), "GET", fmt::format("/api/v1/maps/{}/nothing.png", id)).status, 404);
  EXPECT_EQ(http_request(port(), "GET", fmt::format("/api/v1/maps/{}", id + 1)).status, 404);
  EXPECT_EQ(http_request(port(), "GET", fmt::format("/api/v1/maps/{}/cube", id + 1)).status, 404);
  EXPECT_EQ(http_request(port(), "GET", fmt::format("/api/v1/maps/{}/Melanin.png", id)).status, 404);
}

}  // namespace
}  // namespace skinspec::testing
