// Mutation test: seeded random corruptions of every input file kind
// (scene.json, material.json, OBJ, PLY, IES, EXR/PNG images) run through the
// CLI (`relight`, `evaluate`, `reconstruct`) as child processes. Every run
// must either exit 0 with a valid output, or exit non-zero with a message
// naming the corrupted file or field; never die of a signal, hang, leave a
// temporary or partial folder, or damage the previous result in --out.
//
// Each run works on a mirror of a tiny capture (folders recreated, files
// symlinked) in which only the corrupted file is a real copy, so a run costs
// one short process. The corruption of run i depends only on (kSeed, i).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <numeric>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "io/image.h"
#include "io/material.h"
#include "io/mesh.h"
#include "io/scene.h"
#include "subprocess.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::CliRun;

constexpr uint64_t kSeed = 20261129;
using Rng = std::mt19937_64;

int Pick(Rng& rng, int n) { return static_cast<int>(std::uniform_int_distribution<int>(0, n - 1)(rng)); }
template <class T>
const T& PickOf(Rng& rng, const std::vector<T>& v) { return v[Pick(rng, static_cast<int>(v.size()))]; }

void WriteBytes(const std::string& path, const std::string& bytes) {
  fs::remove(path);  // a symlink into the shared base: replace, never write through it
  std::ofstream(path, std::ios::binary) << bytes;
}

// ---- Corruptions. Each returns a short description for the report. ----

std::string CorruptBytes(Rng& rng, const std::string& path) {
  std::string data = test::ReadText(path);
  if (data.empty()) data = "x";
  std::string what;
  switch (Pick(rng, 4)) {
    case 0: {  // truncation
      const size_t at = std::uniform_int_distribution<size_t>(0, data.size() - 1)(rng);
      data.resize(at);
      what = "truncated at byte " + std::to_string(at);
      break;
    }
    case 1: {  // a few random bytes
      const int n = 1 + Pick(rng, 16);
      for (int k = 0; k < n; ++k) data[std::uniform_int_distribution<size_t>(0, data.size() - 1)(rng)] = char(Pick(rng, 256));
      what = std::to_string(n) + " random bytes";
      break;
    }
    case 2: {  // a random block overwritten (headers, tables)
      const size_t at = std::uniform_int_distribution<size_t>(0, std::min<size_t>(data.size() - 1, 400))(rng);
      for (size_t k = at; k < std::min(data.size(), at + 64); ++k) data[k] = char(Pick(rng, 256));
      what = "64 random bytes at " + std::to_string(at);
      break;
    }
    default: {  // replaced by random bytes of another length
      data.assign(Pick(rng, 2048), '\0');
      for (char& c : data) c = char(Pick(rng, 256));
      what = "random content";
    }
  }
  WriteBytes(path, data);
  return what;
}

// A replacement JSON value that is wrong in kind or range.
json BadValue(Rng& rng, const json& old, std::string* what) {
  static const std::vector<std::pair<const char*, json>> kNumbers = {
      {"huge", 1e308}, {"int max", 2147483647}, {"int64 max", 9223372036854775807LL}, {"negative", -1},
      {"very negative", -1e9}, {"zero", 0}, {"tiny", 1e-300}, {"fraction", 0.5}, {"uint64 max", 18446744073709551615ULL}};
  switch (Pick(rng, 4)) {
    case 0: {
      const auto& [name, v] = PickOf(rng, kNumbers);
      *what = name;
      return v;
    }
    case 1: {
      static const std::vector<json> kTypes = {"text", json::array(), json::object(), true, nullptr, json::array({1, 2})};
      *what = "wrong type";
      return PickOf(rng, kTypes);
    }
    case 2:
      if (old.is_string()) {
        static const std::vector<std::string> kStrings = {"", "missing.exr", "../../../nowhere/x.obj", "/", "a.unknown",
                                                          std::string(300, 'x')};
        *what = "bad string";
        return PickOf(rng, kStrings);
      }
      [[fallthrough]];
    default:
      if (old.is_array() && !old.empty()) {
        json v = old;
        if (Pick(rng, 2) == 0) {
          v.erase(v.begin() + Pick(rng, static_cast<int>(v.size())));
          *what = "array element removed";
        } else {
          v.push_back(v[Pick(rng, static_cast<int>(v.size()))]);
          *what = "array element duplicated";
        }
        return v;
      }
      if (old.is_number()) {
        *what = "scaled by -1e6";
        return old.get<double>() * -1e6;
      }
      *what = "empty array";
      return json::array();
  }
}

// Every JSON pointer below the root.
void Pointers(const json& j, const json::json_pointer& at, std::vector<json::json_pointer>* out) {
  if (j.is_object())
    for (const auto& [k, v] : j.items()) {
      out->push_back(at / k);
      Pointers(v, at / k, out);
    }
  if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) {
      out->push_back(at / i);
      Pointers(j[i], at / i, out);
    }
}

// A field-level corruption of a JSON file; `field` gets the key that an
// error message may name instead of the file.
std::string CorruptJson(Rng& rng, const std::string& path, std::string* field) {
  if (Pick(rng, 5) == 0) return CorruptBytes(rng, path);
  json j = json::parse(test::ReadText(path));
  std::vector<json::json_pointer> ptrs;
  Pointers(j, json::json_pointer(), &ptrs);
  const json::json_pointer p = PickOf(rng, ptrs);
  // The last member name on the path ("params" for /cameras/0/params/2):
  // what an error message names besides the file.
  for (json::json_pointer q = p; !q.empty(); q = q.parent_pointer())
    if (q.back().find_first_not_of("0123456789") != std::string::npos) {
      *field = q.back();
      break;
    }
  std::string what;
  const int op = Pick(rng, 10);
  if (op == 0 && j[p.parent_pointer()].is_object()) {
    j[p.parent_pointer()].erase(p.back());
    what = "removed";
  } else if (op == 1 && j[p].is_object()) {
    j[p]["unexpected_field"] = 1;
    *field = "unexpected_field";
    what = "unknown field added";
  } else if (op == 2) {
    // Non-finite numbers are not JSON; a writer may emit them anyway.
    static const std::vector<std::string> kLiterals = {"NaN", "Infinity", "-inf", "1e999", "nan"};
    const std::string lit = PickOf(rng, kLiterals);
    j[p] = "@@LITERAL@@";
    std::string text = j.dump(2);
    text.replace(text.find("\"@@LITERAL@@\""), 13, lit);
    WriteBytes(path, text);
    return "/" + p.to_string() + " = " + lit;
  } else {
    j[p] = BadValue(rng, j[p], &what);
  }
  WriteBytes(path, j.dump(2));
  return p.to_string() + ": " + what;
}

// A corruption of one line of a text format (OBJ, ASCII PLY, IES).
std::string CorruptLines(Rng& rng, const std::string& path, int header_lines) {
  if (Pick(rng, 4) == 0) return CorruptBytes(rng, path);
  std::vector<std::string> lines;
  {
    std::istringstream in(test::ReadText(path));
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  if (lines.empty()) lines.push_back("");
  // Headers decide how everything after them is read: corrupt them more often.
  const int n = static_cast<int>(lines.size());
  const int i = header_lines > 0 && Pick(rng, 2) == 0 ? Pick(rng, std::min(n, header_lines)) : Pick(rng, n);
  std::string what;
  switch (Pick(rng, 5)) {
    case 0:
      lines.erase(lines.begin() + i);
      what = "line removed";
      break;
    case 1:
      lines.insert(lines.begin() + i, lines[i]);
      what = "line duplicated";
      break;
    default: {
      std::vector<std::string> tokens;
      std::istringstream ls(lines[i]);
      for (std::string t; ls >> t;) tokens.push_back(t);
      if (tokens.empty()) tokens.push_back("");
      static const std::vector<std::string> kTokens = {"nan", "inf", "-1", "0", "1e308", "-1e308", "99999999",
                                                       "4294967296", "abc", "", "1e-320", "2147483648", "-2147483649"};
      const int k = Pick(rng, static_cast<int>(tokens.size()));
      tokens[k] = PickOf(rng, kTokens);
      std::string line;
      for (const std::string& t : tokens) line += (line.empty() ? "" : " ") + t;
      what = "line " + std::to_string(i + 1) + ": '" + lines[i].substr(0, 40) + "' -> '" + line.substr(0, 40) + "'";
      lines[i] = line;
    }
  }
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  WriteBytes(path, text);
  return what;
}

// Pixel-level corruptions of an image that still decodes.
std::string CorruptImage(Rng& rng, const std::string& path) {
  if (Pick(rng, 3) == 0) return CorruptBytes(rng, path);
  Image img = ReadImage(path);
  const std::string ext = fs::path(path).extension().string();
  const bool is_float = ext == ".exr";
  std::string what;
  switch (Pick(rng, is_float ? 6 : 3)) {
    case 0: {  // wrong size
      Image other(std::max(1, img.width + (Pick(rng, 2) ? 1 : -img.width / 2)), img.height, img.channels, 0.3f);
      img = other;
      what = "wrong size";
      break;
    }
    case 1: {  // wrong channel count
      Image other(img.width, img.height, PickOf(rng, std::vector<int>{1, 2, 4}), 0.3f);
      img = other;
      what = "wrong channel count";
      break;
    }
    case 2:
      std::fill(img.pixels.begin(), img.pixels.end(), 0.0f);
      what = "all black";
      break;
    default: {  // non-finite, negative or huge values in a few hundred pixels
      static const std::vector<float> kValues = {NAN, INFINITY, -INFINITY, -1.0f, 3e38f};
      const float v = PickOf(rng, kValues);
      for (int k = 0; k < 300; ++k) img.pixels[std::uniform_int_distribution<size_t>(0, img.pixels.size() - 1)(rng)] = v;
      what = "300 values set to " + std::to_string(v);
    }
  }
  fs::remove(path);
  const PixelFormat format = is_float ? PixelFormat::kFloat : PixelFormat::kUInt8;
  WriteImage(path, img, format);
  return what;
}

// ---- The base data and the mirrors. ----

// Recreates the folder tree of `from` under `to`, with symlinks to its files.
void Mirror(const fs::path& from, const fs::path& to) {
  fs::create_directories(to);
  for (const auto& e : fs::recursive_directory_iterator(from, fs::directory_options::follow_directory_symlink)) {
    const fs::path rel = e.path().lexically_relative(from);  // fs::relative would follow symlinks
    if (e.is_directory()) fs::create_directories(to / rel);
    else fs::create_symlink(fs::absolute(e.path()), to / rel);
  }
}

// The material mesh as PLY with per-vertex UVs (vertices split where UVs differ).
void WritePlyMaterial(const std::string& gt, const std::string& dir, bool binary) {
  fs::create_directories(dir);
  for (const auto& e : fs::directory_iterator(gt))
    if (e.path().filename() != "material.json" && e.path().filename() != "mesh.obj")
      fs::create_symlink(fs::absolute(e.path()), fs::path(dir) / e.path().filename());
  const Mesh m = LoadMesh(gt + "/mesh.obj");
  std::map<std::pair<int, int>, int> index;
  std::vector<std::pair<int, int>> verts;
  std::vector<std::array<int, 3>> faces;
  for (size_t f = 0; f < m.faces.size(); ++f) {
    std::array<int, 3> tri;
    for (int k = 0; k < 3; ++k) {
      const auto key = std::make_pair(m.faces[f][k], m.face_uvs[f][k]);
      auto it = index.find(key);
      if (it == index.end()) it = index.emplace(key, int(verts.size())).first, verts.push_back(key);
      tri[k] = it->second;
    }
    faces.push_back(tri);
  }
  std::ostringstream os;
  os << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\nelement vertex " << verts.size()
     << "\nproperty float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\nelement face "
     << faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& [p, t] : verts) {
    const float v[5] = {float(m.positions[p].x()), float(m.positions[p].y()), float(m.positions[p].z()),
                        float(m.texcoords[t].x()), float(m.texcoords[t].y())};
    if (binary) os.write(reinterpret_cast<const char*>(v), sizeof(v));
    else os << v[0] << ' ' << v[1] << ' ' << v[2] << ' ' << v[3] << ' ' << v[4] << '\n';
  }
  for (const auto& f : faces) {
    if (binary) {
      const unsigned char three = 3;
      os.write(reinterpret_cast<const char*>(&three), 1);
      os.write(reinterpret_cast<const char*>(f.data()), 12);
    } else {
      os << "3 " << f[0] << ' ' << f[1] << ' ' << f[2] << '\n';
    }
  }
  std::ofstream(dir + "/mesh.ply", std::ios::binary) << os.str();
  json j = json::parse(test::ReadText(gt + "/material.json"));
  j["mesh"] = "mesh.ply";
  std::ofstream(dir + "/material.json") << j.dump(2);
}

enum class Command { kRelight, kEvaluate, kReconstruct };

// One kind of corruption: which file of the mirror, how, through which command.
struct Target {
  const char* name;
  Command command;
  int weight;  // share of the runs
  std::function<std::string(Rng&, const fs::path& run, std::string* file, std::string* field)> corrupt;
};

struct Outcome {
  std::string target, corruption, file, field, failure, output;
  bool accepted = false;  // exit 0 with a valid output
};

class MutationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    base_ = fs::temp_directory_path() / ("svbrdf_mutation_" + std::to_string(getpid()));
    fs::remove_all(base_);
    fs::create_directories(base_);
    const std::string b = base_.string();
    // A tiny capture with every light type (goniometric lights read an IES file).
    CliRun r = test::RunCliArgs({"synth", "--preset", "tiny", "--images", "8", "--width", "64", "--height", "48",
                                 "--lights", "mixed", "--out", b + "/cap"},
                                b + "/setup.log");
    ASSERT_TRUE(r.Ok()) << r.output;
    r = test::RunCliArgs({"relight", b + "/cap/gt", b + "/cap/heldout/scene.json", "--out", b + "/relit"}, b + "/setup.log");
    ASSERT_TRUE(r.Ok()) << r.output;
    r = test::RunCliArgs(ReconstructArgs(b), b + "/setup.log");
    ASSERT_TRUE(r.Ok()) << "the uncorrupted capture must reconstruct: " << r.output;
    fs::remove_all(b + "/out");
    WritePlyMaterial(b + "/cap/gt", b + "/ply_ascii", false);
    WritePlyMaterial(b + "/cap/gt", b + "/ply_binary", true);
  }
  static void TearDownTestSuite() { fs::remove_all(base_); }

  static std::vector<std::string> ReconstructArgs(const std::string& root) {
    return {"reconstruct", root + "/cap/scene.json", "--out", root + "/out", "--texture-size", "16",
            "--max-clusters", "2", "--models", "lambert", "--no-report", "--threads", "1"};
  }
  static std::vector<std::string> Args(Command c, const std::string& root, const std::string& material,
                                       const std::string& scene) {
    switch (c) {
      case Command::kRelight:
        return {"relight", root + "/" + material, root + "/" + scene, "--out", root + "/out", "--threads", "1"};
      case Command::kEvaluate:
        return {"evaluate", root + "/relit", root + "/cap/heldout/scene.json"};
      case Command::kReconstruct:
        return ReconstructArgs(root);
    }
    return {};
  }

  // Checks an accepted run's output; returns what is wrong with it, or "".
  static std::string CheckOutput(Command c, const fs::path& run, const std::string& scene, const CliRun& r) {
    const std::string out = (run / "out").string();
    try {
      if (c == Command::kEvaluate) {
        if (r.output.find("mean PSNR") == std::string::npos) return "no summary line";
        if (r.output.find("nan") != std::string::npos) return "NaN in the metrics";
        return "";
      }
      if (c == Command::kReconstruct) {
        const Material m = LoadMaterial(out);
        for (const BasisMaterial& b : m.basis)
          for (double p : b.params)
            if (!std::isfinite(p)) return "non-finite parameter";
        return "";
      }
      const Scene s = LoadScene((run / scene).string());
      for (const ImageEntry& e : s.images) {
        const Image img = ReadImage(out + "/" + e.file);
        for (float v : img.pixels)
          if (!(std::isfinite(v) && v >= 0)) return "rendered value " + std::to_string(v) + " in " + e.file;
      }
      return "";
    } catch (const std::exception& e) {
      return std::string("output does not load: ") + e.what();
    }
  }

  static fs::path base_;
};
fs::path MutationTest::base_;

// A random file of `dir` (relative to the run root) with one of the extensions.
std::string PickFile(Rng& rng, const fs::path& run, const std::string& dir, const std::vector<std::string>& exts) {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(run / dir)) {
    const std::string name = e.path().filename().string();
    if (fs::is_directory(e.path())) continue;
    for (const std::string& x : exts)
      if (name.size() > x.size() && name.compare(name.size() - x.size(), x.size(), x) == 0 &&
          name.find(".mask.") == std::string::npos)
        files.push_back(e.path().lexically_relative(run).string());
  }
  std::sort(files.begin(), files.end());  // directory order is not deterministic
  return files.empty() ? dir : PickOf(rng, files);
}

std::vector<Target> Targets() {
  using R = Rng;
  auto json_target = [](const char* file) {
    return [file](R& rng, const fs::path& run, std::string* f, std::string* field) {
      *f = file;
      return CorruptJson(rng, (run / file).string(), field);
    };
  };
  auto lines_target = [](const char* file, int header) {
    return [file, header](R& rng, const fs::path& run, std::string* f, std::string*) {
      *f = file;
      return CorruptLines(rng, (run / file).string(), header);
    };
  };
  auto image_target = [](const char* dir, std::vector<std::string> exts) {
    return [dir, exts](R& rng, const fs::path& run, std::string* f, std::string*) {
      *f = PickFile(rng, run, dir, exts);
      return CorruptImage(rng, (run / *f).string());
    };
  };
  // Cheap readers get most of the runs; full reconstructions the fewest.
  return {
      {"heldout scene.json -> relight", Command::kRelight, 50, json_target("cap/heldout/scene.json")},
      {"material.json -> relight", Command::kRelight, 45, json_target("cap/gt/material.json")},
      {"material OBJ -> relight", Command::kRelight, 30, lines_target("cap/gt/mesh.obj", 0)},
      {"ASCII PLY -> relight", Command::kRelight, 25, lines_target("ply_ascii/mesh.ply", 10)},
      {"binary PLY -> relight", Command::kRelight, 15,
       [](R& rng, const fs::path& run, std::string* f, std::string*) {
         *f = "ply_binary/mesh.ply";
         return CorruptBytes(rng, (run / *f).string());
       }},
      {"IES -> relight", Command::kRelight, 30, lines_target("cap/lights/lamp.ies", 12)},
      {"material maps -> relight", Command::kRelight, 25, image_target("cap/gt", {".exr", ".png"})},
      {"photos and masks -> evaluate", Command::kEvaluate, 25, image_target("cap/heldout", {".exr", ".png"})},
      {"rendered images -> evaluate", Command::kEvaluate, 15, image_target("relit", {".exr"})},
      {"heldout scene.json -> evaluate", Command::kEvaluate, 15, json_target("cap/heldout/scene.json")},
      {"capture scene.json -> reconstruct", Command::kReconstruct, 10, json_target("cap/scene.json")},
      {"capture photos -> reconstruct", Command::kReconstruct, 8, image_target("cap/images", {".exr"})},
      {"capture OBJ -> reconstruct", Command::kReconstruct, 5, lines_target("cap/mesh.obj", 0)},
      {"IES -> reconstruct", Command::kReconstruct, 4, lines_target("cap/lights/lamp.ies", 12)},
  };
}

// The heldout scene has point lights only; the capture's has the goniometric ones.
const char* SceneOf(const std::string& target) {
  return target.rfind("IES", 0) == 0 ? "cap/scene.json" : "cap/heldout/scene.json";
}

const char* MaterialOf(const std::string& target) {
  if (target.rfind("ASCII PLY", 0) == 0) return "ply_ascii";
  if (target.rfind("binary PLY", 0) == 0) return "ply_binary";
  return "cap/gt";
}

TEST_F(MutationTest, EveryCorruptionIsAValidResultOrANamedError) {
  const std::vector<Target> targets = Targets();
  int total_weight = 0;
  for (const Target& t : targets) total_weight += t.weight;
  ASSERT_EQ(std::gcd(97, total_weight), 1) << "the stride must visit every run";
  // One run per unit of weight (302); SVBRDF_MUTATIONS=N runs the first N
  // only (a quick check: the stride below spreads them over every target).
  const char* env = std::getenv("SVBRDF_MUTATIONS");
  const int runs = env ? std::clamp(std::atoi(env), 1, total_weight) : total_weight;
  std::vector<Outcome> outcomes(runs);
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int i; (i = next++) < runs;) {
      Rng rng(kSeed + 7919 * uint64_t(i));
      // The target of run i: a stride coprime with the total visits every
      // unit of weight once, interleaving the targets.
      int w = int((int64_t(i) * 97) % total_weight), ti = 0;
      while (w >= targets[ti].weight) w -= targets[ti++].weight;
      const Target& target = targets[ti];
      Outcome& o = outcomes[i];
      o.target = target.name;
      const fs::path run = base_ / ("run" + std::to_string(i));
      try {
        fs::remove_all(run);
        for (const char* dir : {"cap", "relit", "ply_ascii", "ply_binary"}) Mirror(base_ / dir, run / dir);
        o.corruption = target.corrupt(rng, run, &o.file, &o.field);
      } catch (const std::exception& e) {
        o.failure = std::string("test could not corrupt: ") + e.what();
        continue;
      }
      // Every fourth run has an earlier result in --out that must survive a failure.
      const bool previous = i % 4 == 0 && target.command != Command::kEvaluate;
      if (previous) {
        fs::create_directories(run / "out");
        std::ofstream(run / "out" / "previous.txt") << "earlier result";
      }
      const CliRun r = test::RunCliArgs(Args(target.command, run.string(), MaterialOf(target.name), SceneOf(target.name)),
                                        (run / "log.txt").string(), 60);
      o.output = r.output.substr(0, 600);
      const std::vector<std::string> left = test::TempLeftovers(run.string());
      if (r.timed_out) o.failure = "timed out";
      else if (r.Signaled()) o.failure = "died with exit status " + std::to_string(r.ExitCode());
      else if (!left.empty()) o.failure = "left " + left[0];
      else if (r.Ok()) {
        o.failure = CheckOutput(target.command, run, SceneOf(target.name), r);
        o.accepted = o.failure.empty();
      } else {
        const std::string name = fs::path(o.file).filename().string();
        const bool named = r.output.find(name) != std::string::npos ||
                           (!o.field.empty() && r.output.find(o.field) != std::string::npos);
        if (r.output.find("error: ") == std::string::npos) o.failure = "no error message";
        else if (!named) o.failure = "message names neither " + name + " nor the field";
        else if (previous && !fs::exists(run / "out" / "previous.txt")) o.failure = "previous result destroyed";
        else if (!previous && fs::exists(run / "out")) o.failure = "partial output folder";
      }
      if (o.failure.empty()) fs::remove_all(run);
    }
  };
  std::thread t1(worker), t2(worker);
  t1.join();
  t2.join();

  // Report: outcomes by target.
  std::map<std::string, std::array<int, 3>> table;  // accepted, named error, failure
  int failures = 0;
  for (const Outcome& o : outcomes) {
    auto& row = table[o.target];
    if (!o.failure.empty()) ++row[2], ++failures;
    else if (o.accepted) ++row[0];
    else ++row[1];
  }
  std::printf("%-36s %8s %8s %8s\n", "corrupted input -> command", "valid", "error", "FAILED");
  for (const auto& [name, row] : table) std::printf("%-36s %8d %8d %8d\n", name.c_str(), row[0], row[1], row[2]);
  std::printf("%d mutations, %d failures\n", runs, failures);
  int shown = 0;
  for (size_t i = 0; i < outcomes.size(); ++i) {
    const Outcome& o = outcomes[i];
    if (o.failure.empty()) continue;
    ADD_FAILURE() << "run " << i << " [" << o.target << "] " << o.file << " (" << o.corruption << "): " << o.failure
                  << "\n" << o.output;
    if (++shown == 25) break;
  }
}

}  // namespace
}  // namespace svbrdf
