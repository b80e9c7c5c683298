// Typed access to JSON documents with error messages that name the file, a
// JSON-path-like field name and the expected form, e.g.
//   "/x/scene.json: images[2].cam_from_world.q: expected array of 4 numbers".
// Every reader of the dataset contract goes through this one helper.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

class JsonField {
 public:
  JsonField(const nlohmann::json& value, std::string file, std::string path = "")
      : value_(&value), file_(std::move(file)), path_(std::move(path)) {}

  const nlohmann::json& json() const { return *value_; }
  const std::string& path() const { return path_; }
  // "file: path" (or just "file" at the root), for messages from other modules.
  std::string Where() const;
  std::string WhereAt(const std::string& key) const { return file_ + ": " + ChildPath(key); }
  // Throws Error "file: path: <what>".
  [[noreturn]] void Fail(const std::string& what) const;
  // Throws Error "file: path.key: <what>", for checks beyond the JSON type.
  [[noreturn]] void FailAt(const std::string& key, const std::string& what) const;

  bool Has(const std::string& key) const;
  // Required member (this must be an object); missing members fail naming
  // the member and what `T` expects.
  template <class T> T Get(const std::string& key) const { return Required(key, Expected<T>()).template As<T>(); }
  template <class T> T GetOr(const std::string& key, const T& fallback) const {
    return Has(key) ? Get<T>(key) : fallback;
  }
  // This value as T: double, int, bool, std::string, Vec2, Vec3, Rgb,
  // Eigen::Vector4d, std::vector<double>.
  template <class T> T As() const;
  // "number", "array of 3 numbers", ...: the form As<T> accepts.
  template <class T> static const char* Expected();

  // Member / element access for nesting (fails if absent or of wrong kind).
  JsonField Member(const std::string& key, const char* expected = "object") const;
  std::vector<JsonField> Items(const std::string& key) const;  // required array member
  std::vector<JsonField> AsItems() const;                      // this value as an array

  // Rejects members not listed, so a typo ("exposre") is not silently ignored.
  void AllowOnly(const std::vector<std::string>& keys) const;
  void RequireObject() const;

 private:
  // The member `key`; if missing, fails with "key: missing, expected <expected>".
  JsonField Required(const std::string& key, const char* expected) const;
  std::string ChildPath(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  const nlohmann::json* value_;
  std::string file_, path_;
};

// Specialisations defined in json_field.cc.
#define SVBRDF_JSON_FIELD_TYPE(T)                  \
  template <> T JsonField::As<T>() const;          \
  template <> const char* JsonField::Expected<T>();
SVBRDF_JSON_FIELD_TYPE(double)
SVBRDF_JSON_FIELD_TYPE(int)
SVBRDF_JSON_FIELD_TYPE(bool)
SVBRDF_JSON_FIELD_TYPE(std::string)
SVBRDF_JSON_FIELD_TYPE(Vec2)
SVBRDF_JSON_FIELD_TYPE(Vec3)
SVBRDF_JSON_FIELD_TYPE(Rgb)
SVBRDF_JSON_FIELD_TYPE(Eigen::Vector4d)
SVBRDF_JSON_FIELD_TYPE(std::vector<double>)
#undef SVBRDF_JSON_FIELD_TYPE

}  // namespace svbrdf
