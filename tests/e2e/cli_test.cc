// The CLI on bad input: a clear message naming the file or field, a non-zero
// exit, and no half-written output.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;

struct Result {
  int code;
  std::string output;
};

Result RunCli(const std::string& args) {
  const std::string cmd = std::string(SVBRDF_CLI) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 512> buf;
  while (pipe && fgets(buf.data(), buf.size(), pipe)) out += buf.data();
  const int status = pipe ? pclose(pipe) : -1;
  return {WEXITSTATUS(status), out};
}

std::string Scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("svbrdf_cli_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

TEST(Cli, MissingSceneNamesTheFile) {
  const std::string dir = Scratch("missing");
  const Result r = RunCli("reconstruct " + dir + "/nope/scene.json --out " + dir + "/mat");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("nope/scene.json"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir + "/mat"));
  fs::remove_all(dir);
}

TEST(Cli, MalformedJsonNamesFileAndField) {
  const std::string dir = Scratch("malformed");
  std::ofstream(dir + "/scene.json") << R"({"format": "svbrdf-scene/1", "mesh": "m.obj", "cameras": [], "lights": [], "images": [{"file": 3}]})";
  const Result r = RunCli("relight " + dir + " " + dir + "/scene.json --out " + dir + "/out");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("error:"), std::string::npos) << r.output;
  std::ofstream(dir + "/broken.json") << "{\"format\": ";
  const Result r2 = RunCli("reconstruct " + dir + "/broken.json --out " + dir + "/mat");
  EXPECT_NE(r2.code, 0);
  EXPECT_NE(r2.output.find("broken.json"), std::string::npos) << r2.output;
  fs::remove_all(dir);
}

TEST(Cli, WrongImageSizeNamesTheView) {
  const std::string dir = Scratch("size");
  ASSERT_EQ(RunCli("synth --preset tiny --images 3 --out " + dir + "/cap").code, 0);
  // Claim a different camera size than the photos have.
  std::ifstream in(dir + "/cap/scene.json");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "\"width\": 160", to = "\"width\": 162";
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << text.substr(0, 300);
  text.replace(at, from.size(), to);
  std::ofstream(dir + "/cap/scene.json") << text;
  const Result r = RunCli("reconstruct " + dir + "/cap/scene.json --out " + dir + "/mat");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("images[0]"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir + "/mat"));
  fs::remove_all(dir);
}

double MeanPsnr(const std::string& evaluate_output) {
  const size_t at = evaluate_output.find("mean PSNR ");
  return at == std::string::npos ? -1.0 : std::stod(evaluate_output.substr(at + 10));
}

// Photos integrate their pixels (synth at 2 x 2 samples too): relight's
// default does, until converged; --spp 1 (the pixel centre) is an option.
TEST(Cli, RelightIntegratesThePixelByDefault) {
  const std::string dir = Scratch("pixel");
  // Photos at 2 x 2 samples a pixel, as the default preset's (tiny's own are at the centre).
  ASSERT_EQ(RunCli("synth --preset tiny --images 3 --spp 2 --out " + dir + "/cap").code, 0);
  const std::string scene = dir + "/cap/scene.json";
  double psnr[3];
  const char* options[3] = {"", "--spp 8 --adaptive-rounds 16", "--spp 1"};
  for (int k = 0; k < 3; ++k) {
    const std::string out = dir + "/relit" + std::to_string(k);
    ASSERT_EQ(RunCli("relight " + dir + "/cap/gt " + scene + " --out " + out + " " + options[k]).code, 0) << options[k];
    const Result e = RunCli("evaluate " + out + " " + scene);
    ASSERT_EQ(e.code, 0) << e.output;
    psnr[k] = MeanPsnr(e.output);
    ASSERT_GT(psnr[k], 0) << e.output;
  }
  EXPECT_DOUBLE_EQ(psnr[0], psnr[1]);  // the default is the converged integral
  EXPECT_GT(psnr[0], psnr[2] + 1.0);   // and the true material agrees with its photos better than at the centre
  std::printf("true material vs its photos: default %.2f dB, pixel centre %.2f dB\n", psnr[0], psnr[2]);
  fs::remove_all(dir);
}

TEST(Cli, EverySubcommandHasHelp) {
  for (const char* sub : {"synth", "relight", "reconstruct", "evaluate"}) {
    const Result r = RunCli(std::string(sub) + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.output.find("Example"), std::string::npos) << sub << ": " << r.output;
  }
}

TEST(Cli, ExportHelpAndBadInputLeaveNoFolder) {
  const Result h = RunCli("export --help");
  EXPECT_EQ(h.code, 0);
  EXPECT_NE(h.output.find("Example"), std::string::npos) << h.output;
  const std::string dir = Scratch("export");
  const Result r = RunCli("export " + dir + "/nope --format gltf --out " + dir + "/out");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find(dir + "/nope"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir + "/out"));
  const Result f = RunCli("export " + dir + " --format obj --out " + dir + "/out");
  EXPECT_NE(f.code, 0);
  EXPECT_NE(f.output.find("obj"), std::string::npos) << f.output;
  for (const auto& e : fs::directory_iterator(dir)) ADD_FAILURE() << "left behind: " << e.path();
  fs::remove_all(dir);
}

// reconstruct --for mitsuba fits only models Mitsuba renders exactly: every
// basis material of the export maps exactly and the export does not warn.
TEST(Cli, ForMitsubaFitsOnlyExactModels) {
  const std::string dir = Scratch("for");
  ASSERT_EQ(RunCli("synth --preset tiny --out " + dir + "/cap").code, 0);
  const std::string scene = dir + "/cap/scene.json";
  const Result r = RunCli("reconstruct " + scene + " --out " + dir + "/mat --for mitsuba --threads 2");
  ASSERT_EQ(r.code, 0) << r.output;
  const Result x = RunCli("export " + dir + "/mat --format mitsuba --out " + dir + "/xml");
  ASSERT_EQ(x.code, 0) << x.output;
  EXPECT_EQ(x.output.find("no exact Mitsuba form"), std::string::npos) << x.output;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir + "/xml/export_report.json"));
  ASSERT_FALSE(report["basis"].empty());
  for (const auto& b : report["basis"]) EXPECT_TRUE(b["exact"].get<bool>()) << b.dump();
  const nlohmann::json summary = nlohmann::json::parse(std::ifstream(dir + "/mat/report/summary.json"));
  EXPECT_EQ(summary["render_target"], "mitsuba");
  // A forced model without an exact form is refused, naming it; nothing is written.
  const Result bad = RunCli("reconstruct " + scene + " --out " + dir + "/bad --for mitsuba --model lafortune-1");
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find("lafortune-1"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir + "/bad"));
  EXPECT_NE(RunCli("reconstruct " + scene + " --out " + dir + "/bad --for blender").code, 0);
  // The glTF export of that material is fitted per texel and says so, naming the refit.
  const Result g = RunCli("export " + dir + "/mat --format gltf --out " + dir + "/gltf");
  ASSERT_EQ(g.code, 0) << g.output;
  EXPECT_NE(g.output.find("--for gltf"), std::string::npos) << g.output;
  fs::remove_all(dir);
}

}  // namespace
