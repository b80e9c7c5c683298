// Reliability of the CLI as a user meets it: broken pixels are rejected and
// counted, a capture without signal is an error that says what to check, and
// no failure or signal leaves a folder that looks complete or destroys a
// previous result.
#include <gtest/gtest.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "io/image.h"
#include "io/material.h"
#include "io/scene.h"
#include "subprocess.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;
using test::CliRun;
using test::RunCliArgs;

class Reliability : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = (fs::temp_directory_path() / ("svbrdf_reliability_" + std::to_string(getpid()))).string();
    fs::remove_all(root_);
    fs::create_directories(root_);
    const CliRun r = RunCliArgs({"synth", "--preset", "tiny", "--images", "10", "--out", root_ + "/cap"}, root_ + "/synth.log");
    ASSERT_TRUE(r.Ok()) << r.output;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // A private copy of the capture for one test.
  std::string CopyCapture(const std::string& name) {
    const std::string dir = root_ + "/" + name;
    fs::remove_all(dir);
    fs::copy(root_ + "/cap", dir, fs::copy_options::recursive);
    return dir;
  }
  static std::vector<std::string> Reconstruct(const std::string& cap, const std::string& out) {
    return {"reconstruct", cap + "/scene.json", "--out", out, "--texture-size", "32", "--max-clusters", "2",
            "--models", "lambert,lafortune-1"};
  }
  static std::string root_;
};
std::string Reliability::root_;

TEST_F(Reliability, NonFinitePixelsAreRejectedAndCounted) {
  // A broken HDR merge: a few hundred NaN and Inf pixels on the object in one photo.
  const std::string cap = CopyCapture("nan");
  const Scene scene = LoadScene(cap + "/scene.json");
  const ImageEntry& e = scene.images[0];
  Image photo = ReadImage(scene.Resolve(e.file));
  const Image mask = ReadImage(scene.Resolve(e.mask));
  int broken = 0;
  for (int y = 0; y < photo.height && broken < 400; ++y)
    for (int x = 0; x < photo.width && broken < 400; ++x)
      if (mask.at(x, y, 0) > 0 && (x + y) % 3 == 0) {
        for (int c = 0; c < photo.channels; ++c)
          photo.at(x, y, c) = broken % 4 == 0 ? INFINITY : (broken % 4 == 1 ? -0.5f : NAN);
        ++broken;
      }
  ASSERT_GT(broken, 200);
  WriteImage(scene.Resolve(e.file), photo, PixelFormat::kFloat);

  const std::string out = root_ + "/nan_out";
  const CliRun r = RunCliArgs(Reconstruct(cap, out), root_ + "/nan.log");
  ASSERT_TRUE(r.Ok()) << r.output;
  EXPECT_NE(r.output.find("non-finite/negative pixel"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("images[0]"), std::string::npos) << "the view is named: " << r.output;
  const nlohmann::json summary = nlohmann::json::parse(test::ReadText(out + "/report/summary.json"));
  EXPECT_GT(summary["samples"]["invalid_pixel"].get<long>(), 0) << summary["samples"].dump();
  const Material m = LoadMaterial(out);
  for (const Image& w : m.weights)
    for (float v : w.pixels) ASSERT_TRUE(std::isfinite(v));
  for (const BasisMaterial& b : m.basis)
    for (double p : b.params) ASSERT_TRUE(std::isfinite(p)) << b.spec.Label();
}

TEST_F(Reliability, BlackPhotosAreANoSignalError) {
  // Lens cap on, or lights off: every photo black.
  const std::string cap = CopyCapture("black");
  const Scene scene = LoadScene(cap + "/scene.json");
  for (const ImageEntry& e : scene.images) {
    Image photo = ReadImage(scene.Resolve(e.file));
    std::fill(photo.pixels.begin(), photo.pixels.end(), 0.0f);
    WriteImage(scene.Resolve(e.file), photo, PixelFormat::kFloat);
  }
  const std::string out = root_ + "/black_out";
  const CliRun r = RunCliArgs(Reconstruct(cap, out), root_ + "/black.log");
  EXPECT_FALSE(r.Signaled()) << r.output;
  EXPECT_NE(r.ExitCode(), 0) << r.output;
  for (const char* word : {"no signal", "exposure", "lights", "masks"})
    EXPECT_NE(r.output.find(word), std::string::npos) << word << ": " << r.output;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_TRUE(test::TempLeftovers(root_).empty());
}

TEST_F(Reliability, SignalLeavesNoFolderAndKeepsThePreviousResult) {
  for (const int sig : {SIGTERM, SIGINT}) {
    SCOPED_TRACE(sig);
    const std::string out = root_ + "/signal_out";
    fs::remove_all(out);
    fs::create_directories(out);
    std::ofstream(out + "/previous.txt") << "an earlier good result";
    const pid_t pid = test::StartCli(Reconstruct(root_ + "/cap", out), root_ + "/signal.log");
    ASSERT_GT(pid, 0);
    // Wait until the command is writing (its temporary folder exists), then interrupt it.
    const std::string tmp = out + ".tmp-" + std::to_string(pid);
    for (int i = 0; i < 3000 && !fs::exists(tmp); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_TRUE(fs::exists(tmp)) << test::ReadText(root_ + "/signal.log");
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(pid, sig);
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
    EXPECT_FALSE(fs::exists(tmp));
    EXPECT_TRUE(fs::exists(out + "/previous.txt")) << "the previous result must survive";
    EXPECT_FALSE(fs::exists(out + "/material.json"));
    EXPECT_TRUE(test::TempLeftovers(root_).empty());
  }
}

TEST_F(Reliability, OutputReplacesThePreviousOnlyWhenComplete) {
  const std::string out = root_ + "/relit";
  fs::create_directories(out);
  std::ofstream(out + "/previous.txt") << "an earlier good result";
  // A failing command keeps the previous folder as it was.
  CliRun r = RunCliArgs({"relight", root_ + "/nowhere", root_ + "/cap/heldout/scene.json", "--out", out}, root_ + "/relit.log");
  EXPECT_NE(r.ExitCode(), 0);
  EXPECT_FALSE(r.Signaled());
  EXPECT_TRUE(fs::exists(out + "/previous.txt"));
  // A successful one replaces it as a whole.
  r = RunCliArgs({"relight", root_ + "/cap/gt", root_ + "/cap/heldout/scene.json", "--out", out}, root_ + "/relit.log");
  ASSERT_TRUE(r.Ok()) << r.output;
  EXPECT_FALSE(fs::exists(out + "/previous.txt"));
  const Scene held = LoadScene(root_ + "/cap/heldout/scene.json");
  for (const ImageEntry& e : held.images) EXPECT_TRUE(fs::exists(out + "/" + e.file)) << e.file;
  EXPECT_TRUE(test::TempLeftovers(root_).empty());
}

}  // namespace
}  // namespace svbrdf
