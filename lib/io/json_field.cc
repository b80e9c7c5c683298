#include "io/json_field.h"

#include <cmath>

#include "core/error.h"

namespace svbrdf {
namespace {

using nlohmann::json;

// A short rendering of the offending value for messages.
std::string Shown(const json& v) {
  std::string s = v.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

bool IsFiniteNumber(const json& v) { return v.is_number() && std::isfinite(v.get<double>()); }

// Numbers of an array of exactly n (n < 0: any length) finite numbers, or false.
bool Numbers(const json& v, int n, std::vector<double>* out) {
  if (!v.is_array() || (n >= 0 && static_cast<int>(v.size()) != n)) return false;
  out->clear();
  for (const json& x : v) {
    if (!IsFiniteNumber(x)) return false;
    out->push_back(x.get<double>());
  }
  return true;
}

}  // namespace

std::string JsonField::Where() const { return path_.empty() ? file_ : file_ + ": " + path_; }

void JsonField::Fail(const std::string& what) const { throw Error(Where() + ": " + what); }

void JsonField::FailAt(const std::string& key, const std::string& what) const {
  throw Error(Msg(file_, ": ", ChildPath(key), ": ", what));
}

void JsonField::RequireObject() const {
  if (!value_->is_object()) Fail("expected object, got " + Shown(*value_));
}

bool JsonField::Has(const std::string& key) const { return value_->is_object() && value_->contains(key); }

JsonField JsonField::Required(const std::string& key, const char* expected) const {
  RequireObject();
  const auto it = value_->find(key);
  if (it == value_->end()) throw Error(Msg(file_, ": ", ChildPath(key), ": missing, expected ", expected));
  return JsonField(*it, file_, ChildPath(key));
}

JsonField JsonField::Member(const std::string& key, const char* expected) const {
  JsonField f = Required(key, expected);
  if (!f.value_->is_object()) f.Fail(Msg("expected ", expected, ", got ", Shown(*f.value_)));
  return f;
}

std::vector<JsonField> JsonField::AsItems() const {
  if (!value_->is_array()) Fail("expected array, got " + Shown(*value_));
  std::vector<JsonField> items;
  for (size_t i = 0; i < value_->size(); ++i) items.emplace_back((*value_)[i], file_, Msg(path_, "[", i, "]"));
  return items;
}

std::vector<JsonField> JsonField::Items(const std::string& key) const { return Required(key, "array").AsItems(); }

void JsonField::AllowOnly(const std::vector<std::string>& keys) const {
  RequireObject();
  for (const auto& [key, value] : value_->items()) {
    bool known = false;
    for (const std::string& k : keys) known = known || k == key;
    if (known) continue;
    std::string list;
    for (const std::string& k : keys) list += (list.empty() ? "" : ", ") + k;
    throw Error(Msg(file_, ": ", ChildPath(key), ": unknown field (expected one of ", list, ")"));
  }
}

template <> const char* JsonField::Expected<double>() { return "number"; }
template <> const char* JsonField::Expected<int>() { return "integer"; }
template <> const char* JsonField::Expected<bool>() { return "true or false"; }
template <> const char* JsonField::Expected<std::string>() { return "string"; }
template <> const char* JsonField::Expected<Vec2>() { return "array of 2 numbers"; }
template <> const char* JsonField::Expected<Vec3>() { return "array of 3 numbers"; }
template <> const char* JsonField::Expected<Rgb>() { return "array of 3 numbers"; }
template <> const char* JsonField::Expected<Eigen::Vector4d>() { return "array of 4 numbers"; }
template <> const char* JsonField::Expected<std::vector<double>>() { return "array of numbers"; }

template <> double JsonField::As<double>() const {
  if (!IsFiniteNumber(*value_)) Fail(Msg("expected number, got ", Shown(*value_)));
  return value_->get<double>();
}

template <> int JsonField::As<int>() const {
  if (!value_->is_number_integer() || value_->get<long long>() != value_->get<int>())
    Fail(Msg("expected integer, got ", Shown(*value_)));
  return value_->get<int>();
}

template <> bool JsonField::As<bool>() const {
  if (!value_->is_boolean()) Fail(Msg("expected true or false, got ", Shown(*value_)));
  return value_->get<bool>();
}

template <> std::string JsonField::As<std::string>() const {
  if (!value_->is_string()) Fail(Msg("expected string, got ", Shown(*value_)));
  return value_->get<std::string>();
}

template <> std::vector<double> JsonField::As<std::vector<double>>() const {
  std::vector<double> v;
  if (!Numbers(*value_, -1, &v)) Fail(Msg("expected array of numbers, got ", Shown(*value_)));
  return v;
}

// Fixed-size vectors share one implementation.
template <class V>
static V FixedVector(const JsonField& f, const json& value) {
  std::vector<double> v;
  if (!Numbers(value, V::RowsAtCompileTime, &v))
    f.Fail(Msg("expected ", JsonField::Expected<V>(), ", got ", Shown(value)));
  return Eigen::Map<const V>(v.data());
}

template <> Vec2 JsonField::As<Vec2>() const { return FixedVector<Vec2>(*this, *value_); }
template <> Vec3 JsonField::As<Vec3>() const { return FixedVector<Vec3>(*this, *value_); }
template <> Rgb JsonField::As<Rgb>() const { return FixedVector<Rgb>(*this, *value_); }
template <> Eigen::Vector4d JsonField::As<Eigen::Vector4d>() const {
  return FixedVector<Eigen::Vector4d>(*this, *value_);
}

}  // namespace svbrdf
