// The JPL text form of a camera model: parseModelText reads it one "KEY = values" line at a time, each line
// copied into a bounded, NUL-terminated buffer (no heap); formatModelText writes it.
#include "firmware_core/camera/CameraModel.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "firmware_core/base/Capacities.hpp"

namespace areomap {
namespace {

constexpr int32_t kComponents = 7;
constexpr const char* kComponentNames[kComponents] = {"C", "A", "H", "V", "O", "R", "E"};

// The components a model of `type` has: C A H V, then O R (CAHVOR), then E (CAHVORE).
int32_t componentCount(CameraType type) {
  return type == CameraType::kCahv ? 4 : (type == CameraType::kCahvor ? 6 : 7);
}

// What the lines read so far have given.
struct TextFields {
  bool seen[kComponents] = {false, false, false, false, false, false, false};  // C A H V O R E
  bool type_given = false;
  CameraType declared = CameraType::kCahv;
  bool kind_given = false;
};

bool keyIs(const char* key, std::size_t key_len, const char* name) {
  return std::strlen(name) == key_len && std::strncmp(key, name, key_len) == 0;
}

bool parseNumbers(const char* values, double* out, int32_t count) {
  const char* cursor = values;
  for (int32_t i = 0; i < count; ++i) {
    char* end = nullptr;
    out[i] = std::strtod(cursor, &end);
    if (end == cursor) {
      return false;
    }
    cursor = end;
  }
  return true;
}

bool allFinite(const double* v, int32_t count) {
  for (int32_t i = 0; i < count; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

// Copies the line that starts at `pos` (up to '\n', NUL or the end) into `line` and moves `pos` past it.
Status nextLine(const char* text, std::size_t length, std::size_t& pos, char* line, const char*& field) {
  std::size_t end = pos;
  while (end < length && text[end] != '\n' && text[end] != '\0') ++end;
  const std::size_t n = end - pos;
  const std::size_t start = pos;
  pos = end + 1;
  if (n > kMaxModelTextLineChars) {
    field = "line";
    return Status::kCapacityExceeded;
  }
  std::memcpy(line, text + start, n);
  line[n] = '\0';
  return Status::kOk;
}

// The key of a "KEY = values" line without the blanks around it, and the text after '='. False for a line
// without '='.
bool splitLine(const char* line, const char*& key, std::size_t& key_len, const char*& values) {
  const char* eq = std::strchr(line, '=');
  if (eq == nullptr) return false;
  key = line;
  while (*key == ' ' || *key == '\t') ++key;
  const char* key_end = eq;
  while (key_end > key && (key_end[-1] == ' ' || key_end[-1] == '\t')) --key_end;
  key_len = static_cast<std::size_t>(key_end - key);
  values = eq + 1;
  return true;
}

// A vector component (C, A, H, V, O, R, E): three finite numbers. `matched` is false for another key.
Status readComponent(const char* key, std::size_t key_len, const char* values, CameraModel& model,
                     TextFields& fields, bool& matched, const char*& field) {
  Vec3* targets[kComponents] = {&model.c, &model.a, &model.h, &model.v, &model.o, &model.r, &model.e};
  matched = false;
  for (int32_t i = 0; i < kComponents && !matched; ++i) {
    if (keyIs(key, key_len, kComponentNames[i])) {
      matched = true;
      double v[3];
      if (!parseNumbers(values, v, 3)) {
        field = kComponentNames[i];
        return Status::kCorruptData;
      }
      if (!allFinite(v, 3)) {
        field = kComponentNames[i];
        return Status::kNotFinite;
      }
      *targets[i] = Vec3(v[0], v[1], v[2]);
      fields.seen[i] = true;
    }
  }
  return Status::kOk;
}

// "Dimensions = width height", each within 0..kMaxModelImageSidePx.
Status readDimensions(const char* values, CameraModel& model, const char*& field) {
  double v[2];
  if (!parseNumbers(values, v, 2) || !allFinite(v, 2) || v[0] < 0.0 || v[1] < 0.0 ||
      v[0] > kMaxModelImageSidePx || v[1] > kMaxModelImageSidePx) {
    field = "Dimensions";
    return Status::kCorruptData;
  }
  model.width = static_cast<int32_t>(v[0]);
  model.height = static_cast<int32_t>(v[1]);
  return Status::kOk;
}

// "Model = CAHVORE3,0.5 = general" (JPL), "Model = CAHVOR", "Model = CAHV".
Status readModelType(const char* values, CameraModel& model, TextFields& fields, const char*& field) {
  const char* t = values;
  while (*t == ' ' || *t == '\t') ++t;
  fields.type_given = true;
  if (std::strncmp(t, "CAHVORE", 7) == 0) {
    fields.declared = CameraType::kCahvore;
    const char* k = t + 7;
    if (*k >= '1' && *k <= '3') {
      model.cahvore_kind = static_cast<CahvoreKind>(*k - '0');
      fields.kind_given = true;
      ++k;
      if (*k == ',') {
        double p = 0.0;
        if (!parseNumbers(k + 1, &p, 1) || !std::isfinite(p)) {
          field = "parameter";
          return Status::kCorruptData;
        }
        model.linearity = p;
      }
    }
  } else if (std::strncmp(t, "CAHVOR", 6) == 0) {
    fields.declared = CameraType::kCahvor;
  } else if (std::strncmp(t, "CAHV", 4) == 0) {
    fields.declared = CameraType::kCahv;
  } else {
    field = "Model";
    return Status::kUnsupported;
  }
  return Status::kOk;
}

// One "KEY = values" line; keys the form does not have are ignored.
Status readLine(const char* key, std::size_t key_len, const char* values, CameraModel& model,
                TextFields& fields, const char*& field) {
  bool matched = false;
  const Status s = readComponent(key, key_len, values, model, fields, matched, field);
  if (matched) return s;
  if (keyIs(key, key_len, "Dimensions")) return readDimensions(values, model, field);
  if (keyIs(key, key_len, "Model")) return readModelType(values, model, fields, field);
  if (keyIs(key, key_len, "T")) {  // CAHVORE type alone (1, 2, 3)
    double v = 0.0;
    if (!parseNumbers(values, &v, 1) || !(v == 1.0 || v == 2.0 || v == 3.0)) {
      field = "T";
      return Status::kCorruptData;
    }
    model.cahvore_kind = static_cast<CahvoreKind>(static_cast<int32_t>(v));
    fields.kind_given = true;
  } else if (keyIs(key, key_len, "P")) {  // CAHVORE parameter alone
    double v = 0.0;
    if (!parseNumbers(values, &v, 1) || !std::isfinite(v)) {
      field = "P";
      return Status::kCorruptData;
    }
    model.linearity = v;
  }
  return Status::kOk;
}

// After the last line: C A H V are required; the type is the declared one, else the one the components given
// imply; the type's other components are then required; a CAHVORE without a kind is perspective, and a
// perspective or fisheye one has its fixed linearity.
Status finishModel(CameraModel& model, const TextFields& fields, const char*& field) {
  for (int32_t i = 0; i < 4; ++i) {
    if (!fields.seen[i]) {
      field = kComponentNames[i];
      return Status::kMissingField;
    }
  }
  if (fields.type_given) {
    model.type = fields.declared;
  } else if (fields.seen[6]) {
    model.type = CameraType::kCahvore;
  } else if (fields.seen[4] || fields.seen[5]) {
    model.type = CameraType::kCahvor;
  }
  const int32_t needed = componentCount(model.type);
  for (int32_t i = 4; i < needed; ++i) {
    if (!fields.seen[i]) {
      field = kComponentNames[i];
      return Status::kMissingField;
    }
  }
  if (model.type == CameraType::kCahvore && !fields.kind_given) {
    model.cahvore_kind = CahvoreKind::kPerspective;
  }
  if (model.type == CameraType::kCahvore && model.cahvore_kind != CahvoreKind::kGeneral) {
    model.linearity = cahvoreLinearity(model);
  }
  return Status::kOk;
}

}  // namespace

Status parseModelText(const char* text, std::size_t length, CameraModel& model, const char*& field) {
  field = "";
  model = CameraModel{};
  TextFields fields;
  char line[kMaxModelTextLineChars + 1];
  std::size_t pos = 0;
  while (pos < length) {  // bounded by length: every pass consumes at least one character
    Status s = nextLine(text, length, pos, line, field);
    if (!ok(s)) return s;
    const char* key = nullptr;
    std::size_t key_len = 0;
    const char* values = nullptr;
    if (!splitLine(line, key, key_len, values)) continue;
    s = readLine(key, key_len, values, model, fields, field);
    if (!ok(s)) return s;
  }
  const Status s = finishModel(model, fields, field);
  if (!ok(s)) return s;
  return validateModel(model, field);
}

std::size_t formatModelText(const CameraModel& model, char* buffer, std::size_t capacity) {
  if (buffer == nullptr || capacity == 0) {
    return 0;
  }
  std::size_t used = 0;
  bool fits = true;
  auto append = [&](int written) {
    if (written < 0 || static_cast<std::size_t>(written) >= capacity - used) {
      fits = false;
      return;
    }
    used += static_cast<std::size_t>(written);
  };
  switch (model.type) {
    case CameraType::kCahv:
      append(std::snprintf(buffer + used, capacity - used, "Model = CAHV\n"));
      break;
    case CameraType::kCahvor:
      append(std::snprintf(buffer + used, capacity - used, "Model = CAHVOR\n"));
      break;
    case CameraType::kCahvore: {
      const char* kind_name = model.cahvore_kind == CahvoreKind::kPerspective
                                  ? "perspective"
                                  : (model.cahvore_kind == CahvoreKind::kFisheye ? "fisheye" : "general");
      append(std::snprintf(buffer + used, capacity - used, "Model = CAHVORE%d,%.17g = %s\n",
                           static_cast<int>(model.cahvore_kind), model.linearity, kind_name));
      break;
    }
  }
  if (fits && model.width > 0 && model.height > 0) {
    append(std::snprintf(buffer + used, capacity - used, "Dimensions = %d %d\n",
                         static_cast<int>(model.width), static_cast<int>(model.height)));
  }
  const Vec3* vectors[] = {&model.c, &model.a, &model.h, &model.v, &model.o, &model.r, &model.e};
  const int32_t count = componentCount(model.type);
  for (int32_t i = 0; i < count && fits; ++i) {
    append(std::snprintf(buffer + used, capacity - used, "%s = %.17g %.17g %.17g\n", kComponentNames[i],
                         vectors[i]->x(), vectors[i]->y(), vectors[i]->z()));
  }
  if (!fits) {
    buffer[0] = '\0';
    return 0;
  }
  return used;
}

}  // namespace areomap
