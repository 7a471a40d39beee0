#pragma once

// The names of an options enum's values, in one table per enum, defined
// beside the enum:
//   enum class CostType { kBata, kChordal };
//   template <>
//   const EnumNames<CostType>& NamesOf<CostType>();  // {{kBata, "bata"}, ...}
// Parsing, printing and the list of allowed values for errors and help all
// come from that table (OptionManager registers such a member as a choice).

#include <string>
#include <utility>
#include <vector>

namespace colmap_irav4 {

template <typename Enum>
using EnumNames = std::vector<std::pair<Enum, std::string>>;

// Specialised (declared in the enum's header, defined in its .cc) per enum.
template <typename Enum>
const EnumNames<Enum>& NamesOf();

// The value's name (the first of its names).
template <typename Enum>
std::string EnumName(Enum value) {
  for (const auto& [candidate, name] : NamesOf<Enum>()) {
    if (candidate == value) return name;
  }
  return "?";
}

// Sets *value to the value named `text`; false when no value has that name.
template <typename Enum>
bool ParseEnum(const std::string& text, Enum* value) {
  for (const auto& [candidate, name] : NamesOf<Enum>()) {
    if (name == text) {
      *value = candidate;
      return true;
    }
  }
  return false;
}

// "a, b or c": the allowed names, for errors and help.
template <typename Enum>
std::string EnumNameList() {
  const EnumNames<Enum>& names = NamesOf<Enum>();
  std::string list;
  for (size_t k = 0; k < names.size(); ++k) {
    if (k > 0) list += k + 1 == names.size() ? " or " : ", ";
    list += names[k].second;
  }
  return list;
}

}  // namespace colmap_irav4
