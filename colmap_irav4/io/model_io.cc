#include "colmap_irav4/io/model_io.h"

#include <glog/logging.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

std::string JoinPath(const std::string& dir, const std::string& name) {
  return (fs::path(dir) / name).string();
}

std::string ReadFileBytes(const std::string& path) {
  if (!fs::exists(path)) throw InputError(path, "file does not exist");
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path, "cannot open file");
  std::ostringstream bytes;
  bytes << file.rdbuf();
  if (file.bad()) throw InputError(path, "read error");
  return bytes.str();
}

// ---------------------------------------------------------------------------
// Binary encoding: little-endian, as COLMAP writes it on every platform.

template <typename T>
T FromLittleEndian(T value) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  char* bytes = reinterpret_cast<char*>(&value);
  std::reverse(bytes, bytes + sizeof(T));
#endif
  return value;
}

template <typename T>
void AppendBinary(T value, std::string* out) {
  value = FromLittleEndian(value);  // the swap is its own inverse
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Bounds-checked reading of a binary file held in memory.
class BinaryReader {
 public:
  BinaryReader(std::string path, std::string data)
      : path_(std::move(path)), data_(std::move(data)) {}

  template <typename T>
  T Read(const char* what) {
    Require(sizeof(T), what);
    T value;
    std::memcpy(&value, data_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return FromLittleEndian(value);
  }

  // Null-terminated string.
  std::string ReadString(const char* what) {
    const size_t end = data_.find('\0', offset_);
    if (end == std::string::npos) {
      throw InputError(path_, std::string("truncated file: unterminated ") +
                                  what + " at byte " + std::to_string(offset_));
    }
    std::string value = data_.substr(offset_, end - offset_);
    offset_ = end + 1;
    return value;
  }

  // A count of records of at least `min_record_size` bytes each: a count the
  // rest of the file cannot hold means a truncated or garbage file (and must
  // not reach a reserve()).
  uint64_t ReadCount(const char* what, size_t min_record_size) {
    const uint64_t count = Read<uint64_t>(what);
    if (min_record_size > 0 && count > Remaining() / min_record_size) {
      throw InputError(
          path_, "truncated or corrupt file: " + std::string(what) + " is " +
                     std::to_string(count) + " at byte " +
                     std::to_string(offset_ - 8) + " but only " +
                     std::to_string(Remaining()) + " bytes follow");
    }
    return count;
  }

  size_t Remaining() const { return data_.size() - offset_; }
  size_t offset() const { return offset_; }
  const std::string& path() const { return path_; }

  void ExpectEnd() const {
    if (offset_ != data_.size()) {
      throw InputError(path_, std::to_string(data_.size() - offset_) +
                                  " unexpected bytes after the last record");
    }
  }

 private:
  void Require(size_t size, const char* what) const {
    if (data_.size() - offset_ < size) {
      throw InputError(path_, std::string("truncated file: cannot read ") +
                                  what + " at byte " + std::to_string(offset_) +
                                  " (file has " + std::to_string(data_.size()) +
                                  " bytes)");
    }
  }

  std::string path_;
  std::string data_;
  size_t offset_ = 0;
};

// ---------------------------------------------------------------------------
// Text parsing.

std::string Trim(const std::string& s) {
  size_t begin = 0;
  size_t end = s.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(s[begin]))) {
    ++begin;
  }
  while (end > begin && std::isspace(static_cast<unsigned char>(s[end - 1]))) {
    --end;
  }
  return s.substr(begin, end - begin);
}

std::vector<std::string> SplitWhitespace(const std::string& line) {
  std::vector<std::string> tokens;
  std::istringstream stream(line);
  std::string token;
  while (stream >> token) tokens.push_back(token);
  return tokens;
}

// Reads a text file line by line, with its line number for messages.
class TextReader {
 public:
  explicit TextReader(const std::string& path) : path_(path) {
    data_.str(ReadFileBytes(path));
  }

  // Next line that is neither empty nor a comment; false at the end.
  bool NextDataLine(std::string* line) {
    while (NextLine(line)) {
      if (!line->empty() && (*line)[0] != '#') return true;
    }
    return false;
  }

  // Next line, whatever it holds (trimmed); false at the end.
  bool NextLine(std::string* line) {
    if (!std::getline(data_, *line)) return false;
    ++line_number_;
    *line = Trim(*line);
    return true;
  }

  [[noreturn]] void Fail(const std::string& problem) const {
    throw InputError(path_,
                     "line " + std::to_string(line_number_) + ": " + problem);
  }

  double ParseDouble(const std::string& token, const char* what) const {
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (token.empty() || end != token.c_str() + token.size() ||
        (errno == ERANGE && std::abs(value) > 1.0)) {
      Fail(std::string("invalid ") + what + " '" + token + "'");
    }
    return value;
  }

  uint64_t ParseUInt(const std::string& token, const char* what,
                     uint64_t max_value) const {
    errno = 0;
    char* end = nullptr;
    const unsigned long long value = std::strtoull(token.c_str(), &end, 10);
    if (token.empty() || token[0] == '-' || token[0] == '+' ||
        end != token.c_str() + token.size() || errno == ERANGE ||
        value > max_value) {
      Fail(std::string("invalid ") + what + " '" + token + "'");
    }
    return value;
  }

  const std::string& path() const { return path_; }
  int line_number() const { return line_number_; }

 private:
  std::string path_;
  std::istringstream data_;
  int line_number_ = 0;
};

// ---------------------------------------------------------------------------
// Checks shared by the binary and text readers.

// Problems of one record given the records read before; "" if none.
std::string CameraRecordProblem(const Camera& camera,
                                const Reconstruction& reconstruction) {
  if (camera.camera_id == kInvalidCameraId) {
    return "invalid camera id " + std::to_string(camera.camera_id);
  }
  if (!IsValidCameraModelId(camera.model_id)) {
    return "camera " + std::to_string(camera.camera_id) +
           " has unknown camera model id " + std::to_string(camera.model_id) +
           " (supported: COLMAP 3.8's ids 0-10)";
  }
  if (reconstruction.cameras.count(camera.camera_id) > 0) {
    return "duplicate camera id " + std::to_string(camera.camera_id);
  }
  return "";
}

std::string ImageRecordProblem(const Image& image,
                               const Reconstruction& reconstruction) {
  const std::string id = std::to_string(image.image_id);
  if (image.image_id == kInvalidImageId) {
    return "invalid image id " + id;
  }
  if (reconstruction.images.count(image.image_id) > 0) {
    return "duplicate image id " + id;
  }
  // COLMAP normalises the quaternion it reads; a zero or non-finite one is
  // no rotation at all.
  const Eigen::Quaterniond& q = image.cam_from_world.rotation;
  const double norm = q.coeffs().norm();
  if (!std::isfinite(norm) || !(norm > 1e-8)) {
    std::ostringstream value;
    value << q.w() << " " << q.x() << " " << q.y() << " " << q.z();
    return "image " + id + " (" + image.name +
           ") has an invalid rotation "
           "quaternion (" +
           value.str() + ")";
  }
  if (!image.cam_from_world.translation.allFinite()) {
    return "image " + id + " (" + image.name + ") has a non-finite translation";
  }
  if (reconstruction.cameras.count(image.camera_id) == 0) {
    return "image " + id + " (" + image.name + ") references camera " +
           std::to_string(image.camera_id) +
           ", which is not in the cameras file";
  }
  return "";
}

std::string PointRecordProblem(point3D_t point3D_id,
                               const Reconstruction& reconstruction) {
  if (point3D_id == kInvalidPoint3DId) {
    return "invalid point3D id " + std::to_string(point3D_id);
  }
  if (reconstruction.points3D.count(point3D_id) > 0) {
    return "duplicate point3D id " + std::to_string(point3D_id);
  }
  return "";
}

// Every track element must be an observation of its image that names the
// point, and every observation naming a point must be in its track, once.
void CheckTracks(const std::string& path,
                 const Reconstruction& reconstruction) {
  std::map<image_t, std::vector<bool>> claimed;
  for (const auto& [image_id, image] : reconstruction.images) {
    claimed[image_id].assign(image.points2D.size(), false);
  }
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    const std::string id = std::to_string(point3D_id);
    for (const TrackElement& element : point.track) {
      const auto image_it = reconstruction.images.find(element.image_id);
      if (image_it == reconstruction.images.end()) {
        throw InputError(path, "point3D " + id + ": track references image " +
                                   std::to_string(element.image_id) +
                                   ", which is not in the images file");
      }
      const Image& image = image_it->second;
      if (element.point2D_idx >= image.points2D.size()) {
        throw InputError(
            path, "point3D " + id + ": track references point2D " +
                      std::to_string(element.point2D_idx) + " of image " +
                      std::to_string(element.image_id) + ", which has " +
                      std::to_string(image.points2D.size()));
      }
      if (image.points2D[element.point2D_idx].point3D_id != point3D_id) {
        throw InputError(
            path,
            "point3D " + id + ": track element (" +
                std::to_string(element.image_id) + ", " +
                std::to_string(element.point2D_idx) +
                ") disagrees with the images file, which gives point3D " +
                std::to_string(image.points2D[element.point2D_idx].point3D_id));
      }
      std::vector<bool>& image_claimed = claimed[element.image_id];
      if (image_claimed[element.point2D_idx]) {
        throw InputError(path, "point3D " + id + ": track element (" +
                                   std::to_string(element.image_id) + ", " +
                                   std::to_string(element.point2D_idx) +
                                   ") appears twice");
      }
      image_claimed[element.point2D_idx] = true;
    }
  }
  for (const auto& [image_id, image] : reconstruction.images) {
    const std::vector<bool>& image_claimed = claimed[image_id];
    for (size_t idx = 0; idx < image.points2D.size(); ++idx) {
      const point3D_t point3D_id = image.points2D[idx].point3D_id;
      if (point3D_id != kInvalidPoint3DId && !image_claimed[idx]) {
        throw InputError(path,
                         "image " + std::to_string(image_id) + " point2D " +
                             std::to_string(idx) + " references point3D " +
                             std::to_string(point3D_id) +
                             (reconstruction.points3D.count(point3D_id) > 0
                                  ? ", whose track does not contain it"
                                  : ", which is not in the points3D file"));
      }
    }
  }
}

// ---------------------------------------------------------------------------
// Text formatting: COLMAP streams numbers with precision 17.

std::ostringstream MakeTextStream() {
  std::ostringstream stream;
  stream.precision(17);
  return stream;
}

// Whether a quaternion's squared norm is 1 to rounding: such a quaternion is
// read and written bit for bit, as normalising it again may change its last
// bits and reading and writing a model would then not give the same bytes.
bool IsUnitToRounding(double squared_norm) {
  return std::abs(squared_norm - 1.0) <=
         8 * std::numeric_limits<double>::epsilon();
}

// (qw, qx, qy, qz) as COLMAP 3.8 writes it: divided by its norm, unless of
// unit norm to rounding (so that a model COLMAP wrote is written back byte
// for byte, and ours match what COLMAP writes from the same pose).
Eigen::Vector4d WrittenQuaternion(const Image& image) {
  const Eigen::Quaterniond& q = image.cam_from_world.rotation;
  const Eigen::Vector4d qvec(q.w(), q.x(), q.y(), q.z());
  if (IsUnitToRounding(qvec.squaredNorm())) return qvec;
  const double norm = qvec.norm();
  if (norm == 0.0) return Eigen::Vector4d(1.0, qvec(1), qvec(2), qvec(3));
  return qvec / norm;
}

// COLMAP normalises the quaternion it reads (see IsUnitToRounding).
void NormalizeReadQuaternion(Eigen::Quaterniond* q) {
  if (!IsUnitToRounding(q->squaredNorm())) q->normalize();
}

}  // namespace

// ---------------------------------------------------------------------------
// Binary reading.

void ReadCamerasBinary(const std::string& path,
                       Reconstruction* reconstruction) {
  BinaryReader reader(path, ReadFileBytes(path));
  // Smallest record: id, model, width, height, 3 parameters.
  const uint64_t num_cameras = reader.ReadCount("number of cameras", 24 + 24);
  for (uint64_t i = 0; i < num_cameras; ++i) {
    Camera camera;
    camera.camera_id = reader.Read<uint32_t>("camera id");
    camera.model_id = reader.Read<int32_t>("camera model id");
    camera.width = reader.Read<uint64_t>("camera width");
    camera.height = reader.Read<uint64_t>("camera height");
    const std::string problem = CameraRecordProblem(camera, *reconstruction);
    if (!problem.empty()) throw InputError(path, problem);
    camera.params.resize(CameraModelNumParams(camera.model_id));
    for (double& param : camera.params) {
      param = reader.Read<double>("camera parameter");
    }
    reconstruction->cameras.emplace(camera.camera_id, std::move(camera));
  }
  reader.ExpectEnd();
}

void ReadImagesBinary(const std::string& path, Reconstruction* reconstruction) {
  BinaryReader reader(path, ReadFileBytes(path));
  // Smallest record: id, pose, camera id, empty name, number of points2D.
  const uint64_t num_images =
      reader.ReadCount("number of images", 4 + 56 + 4 + 1 + 8);
  for (uint64_t i = 0; i < num_images; ++i) {
    Image image;
    image.image_id = reader.Read<uint32_t>("image id");
    Eigen::Quaterniond& q = image.cam_from_world.rotation;
    q.w() = reader.Read<double>("image qvec");
    q.x() = reader.Read<double>("image qvec");
    q.y() = reader.Read<double>("image qvec");
    q.z() = reader.Read<double>("image qvec");
    for (int k = 0; k < 3; ++k) {
      image.cam_from_world.translation(k) = reader.Read<double>("image tvec");
    }
    image.camera_id = reader.Read<uint32_t>("image camera id");
    image.name = reader.ReadString("image name");
    const uint64_t num_points2D =
        reader.ReadCount("number of points2D", 8 + 8 + 8);
    const std::string problem = ImageRecordProblem(image, *reconstruction);
    if (!problem.empty()) throw InputError(path, problem);
    NormalizeReadQuaternion(&image.cam_from_world.rotation);
    image.points2D.resize(num_points2D);
    for (Point2D& point2D : image.points2D) {
      point2D.xy.x() = reader.Read<double>("point2D x");
      point2D.xy.y() = reader.Read<double>("point2D y");
      point2D.point3D_id = reader.Read<uint64_t>("point2D point3D id");
    }
    reconstruction->images.emplace(image.image_id, std::move(image));
  }
  reader.ExpectEnd();
}

void ReadPoints3DBinary(const std::string& path,
                        Reconstruction* reconstruction) {
  BinaryReader reader(path, ReadFileBytes(path));
  const uint64_t num_points =
      reader.ReadCount("number of points3D", 8 + 24 + 3 + 8 + 8);
  for (uint64_t i = 0; i < num_points; ++i) {
    const point3D_t point3D_id = reader.Read<uint64_t>("point3D id");
    const std::string problem = PointRecordProblem(point3D_id, *reconstruction);
    if (!problem.empty()) throw InputError(path, problem);
    Point3D point;
    for (int k = 0; k < 3; ++k)
      point.xyz(k) = reader.Read<double>("point3D xyz");
    for (int k = 0; k < 3; ++k)
      point.color(k) = reader.Read<uint8_t>("point3D color");
    point.error = reader.Read<double>("point3D error");
    const uint64_t track_length = reader.ReadCount("track length", 8);
    point.track.resize(track_length);
    for (TrackElement& element : point.track) {
      element.image_id = reader.Read<uint32_t>("track image id");
      element.point2D_idx = reader.Read<uint32_t>("track point2D index");
    }
    reconstruction->points3D.emplace(point3D_id, std::move(point));
  }
  reader.ExpectEnd();
  CheckTracks(path, *reconstruction);
}

// ---------------------------------------------------------------------------
// Text reading.

void ReadCamerasText(const std::string& path, Reconstruction* reconstruction) {
  TextReader reader(path);
  std::string line;
  while (reader.NextDataLine(&line)) {
    const std::vector<std::string> tokens = SplitWhitespace(line);
    if (tokens.size() < 4) {
      reader.Fail("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got '" +
                  line + "'");
    }
    Camera camera;
    camera.camera_id = static_cast<camera_t>(reader.ParseUInt(
        tokens[0], "camera id", std::numeric_limits<camera_t>::max()));
    camera.model_id = CameraModelNameToId(tokens[1]);
    if (camera.model_id < 0) {
      reader.Fail("unknown camera model '" + tokens[1] +
                  "' (supported: COLMAP 3.8's eleven models)");
    }
    camera.width = reader.ParseUInt(tokens[2], "width",
                                    std::numeric_limits<uint64_t>::max());
    camera.height = reader.ParseUInt(tokens[3], "height",
                                     std::numeric_limits<uint64_t>::max());
    const int num_params = CameraModelNumParams(camera.model_id);
    if (static_cast<int>(tokens.size()) - 4 != num_params) {
      reader.Fail("camera model " + tokens[1] + " has " +
                  std::to_string(num_params) + " parameters (" +
                  CameraModelParamsInfo(camera.model_id) + "), got " +
                  std::to_string(tokens.size() - 4));
    }
    for (int i = 0; i < num_params; ++i) {
      camera.params.push_back(reader.ParseDouble(tokens[4 + i], "parameter"));
    }
    const std::string problem = CameraRecordProblem(camera, *reconstruction);
    if (!problem.empty()) reader.Fail(problem);
    reconstruction->cameras.emplace(camera.camera_id, std::move(camera));
  }
}

void ReadImagesText(const std::string& path, Reconstruction* reconstruction) {
  TextReader reader(path);
  std::string line;
  while (reader.NextDataLine(&line)) {
    std::vector<std::string> tokens = SplitWhitespace(line);
    if (tokens.size() < 10) {
      reader.Fail(
          "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got '" +
          line + "'");
    }
    Image image;
    image.image_id = static_cast<image_t>(reader.ParseUInt(
        tokens[0], "image id", std::numeric_limits<image_t>::max()));
    Eigen::Quaterniond& q = image.cam_from_world.rotation;
    q.w() = reader.ParseDouble(tokens[1], "QW");
    q.x() = reader.ParseDouble(tokens[2], "QX");
    q.y() = reader.ParseDouble(tokens[3], "QY");
    q.z() = reader.ParseDouble(tokens[4], "QZ");
    for (int k = 0; k < 3; ++k) {
      image.cam_from_world.translation(k) =
          reader.ParseDouble(tokens[5 + k], "translation");
    }
    image.camera_id = static_cast<camera_t>(reader.ParseUInt(
        tokens[8], "camera id", std::numeric_limits<camera_t>::max()));
    // The name is the rest of the line (COLMAP names have no spaces, but
    // keep any rather than fail). The separators are SplitWhitespace's
    // (isspace: a vertical tab or form feed too), so that the ten tokens
    // found there are found here.
    constexpr char kSpaces[] = " \t\n\v\f\r";
    size_t name_begin = 0;
    for (int k = 0; k < 9; ++k) {
      name_begin = line.find_first_not_of(kSpaces, name_begin);
      name_begin = line.find_first_of(kSpaces, name_begin);
    }
    CHECK_NE(name_begin, std::string::npos);  // tokens.size() >= 10
    image.name = Trim(line.substr(name_begin));
    const std::string problem = ImageRecordProblem(image, *reconstruction);
    if (!problem.empty()) reader.Fail(problem);
    NormalizeReadQuaternion(&image.cam_from_world.rotation);
    // The POINTS2D line always follows (empty if the image has none).
    if (!reader.NextLine(&line)) {
      reader.Fail("missing POINTS2D line of image " +
                  std::to_string(image.image_id));
    }
    tokens = SplitWhitespace(line);
    if (tokens.size() % 3 != 0) {
      reader.Fail("POINTS2D of image " + std::to_string(image.image_id) +
                  " must be (X, Y, POINT3D_ID) triples, got " +
                  std::to_string(tokens.size()) + " values");
    }
    image.points2D.resize(tokens.size() / 3);
    for (size_t i = 0; i < image.points2D.size(); ++i) {
      Point2D& point2D = image.points2D[i];
      point2D.xy.x() = reader.ParseDouble(tokens[3 * i], "point2D x");
      point2D.xy.y() = reader.ParseDouble(tokens[3 * i + 1], "point2D y");
      const std::string& id = tokens[3 * i + 2];
      point2D.point3D_id =
          id == "-1" ? kInvalidPoint3DId
                     : reader.ParseUInt(id, "point3D id", kInvalidPoint3DId);
    }
    reconstruction->images.emplace(image.image_id, std::move(image));
  }
}

void ReadPoints3DText(const std::string& path, Reconstruction* reconstruction) {
  TextReader reader(path);
  std::string line;
  while (reader.NextDataLine(&line)) {
    const std::vector<std::string> tokens = SplitWhitespace(line);
    if (tokens.size() < 8 || (tokens.size() - 8) % 2 != 0) {
      reader.Fail(
          "expected POINT3D_ID X Y Z R G B ERROR then (IMAGE_ID, "
          "POINT2D_IDX) pairs, got " +
          std::to_string(tokens.size()) + " values");
    }
    const point3D_t point3D_id =
        reader.ParseUInt(tokens[0], "point3D id", kInvalidPoint3DId);
    const std::string problem = PointRecordProblem(point3D_id, *reconstruction);
    if (!problem.empty()) reader.Fail(problem);
    Point3D point;
    for (int k = 0; k < 3; ++k) {
      point.xyz(k) = reader.ParseDouble(tokens[1 + k], "coordinate");
    }
    for (int k = 0; k < 3; ++k) {
      point.color(k) =
          static_cast<uint8_t>(reader.ParseUInt(tokens[4 + k], "color", 255));
    }
    point.error = reader.ParseDouble(tokens[7], "error");
    for (size_t i = 8; i < tokens.size(); i += 2) {
      TrackElement element;
      element.image_id = static_cast<image_t>(reader.ParseUInt(
          tokens[i], "track image id", std::numeric_limits<image_t>::max()));
      element.point2D_idx = static_cast<point2D_t>(
          reader.ParseUInt(tokens[i + 1], "track point2D index",
                           std::numeric_limits<point2D_t>::max()));
      point.track.push_back(element);
    }
    reconstruction->points3D.emplace(point3D_id, std::move(point));
  }
  CheckTracks(path, *reconstruction);
}

// ---------------------------------------------------------------------------
// Whole models.

bool ExistsBinaryModel(const std::string& path) {
  return fs::is_regular_file(JoinPath(path, "cameras.bin")) &&
         fs::is_regular_file(JoinPath(path, "images.bin")) &&
         fs::is_regular_file(JoinPath(path, "points3D.bin"));
}

bool ExistsTextModel(const std::string& path) {
  return fs::is_regular_file(JoinPath(path, "cameras.txt")) &&
         fs::is_regular_file(JoinPath(path, "images.txt")) &&
         fs::is_regular_file(JoinPath(path, "points3D.txt"));
}

namespace {

// A model with a NaN or inf anywhere is refused, read or written.
void ThrowIfNonFinite(const std::string& path,
                      const Reconstruction& reconstruction,
                      const std::string& consequence) {
  const std::string problem = NonFiniteValueProblem(reconstruction);
  if (!problem.empty()) throw InputError(path, problem + consequence);
}

}  // namespace

Reconstruction ReadReconstructionBinary(const std::string& path) {
  Reconstruction reconstruction;
  ReadCamerasBinary(JoinPath(path, "cameras.bin"), &reconstruction);
  ReadImagesBinary(JoinPath(path, "images.bin"), &reconstruction);
  ReadPoints3DBinary(JoinPath(path, "points3D.bin"), &reconstruction);
  ThrowIfNonFinite(path, reconstruction, " (a damaged model)");
  return reconstruction;
}

Reconstruction ReadReconstructionText(const std::string& path) {
  Reconstruction reconstruction;
  ReadCamerasText(JoinPath(path, "cameras.txt"), &reconstruction);
  ReadImagesText(JoinPath(path, "images.txt"), &reconstruction);
  ReadPoints3DText(JoinPath(path, "points3D.txt"), &reconstruction);
  ThrowIfNonFinite(path, reconstruction, " (a damaged model)");
  return reconstruction;
}

Reconstruction ReadReconstruction(const std::string& path) {
  if (!fs::is_directory(path)) {
    throw InputError(path, "model directory does not exist");
  }
  if (ExistsBinaryModel(path)) return ReadReconstructionBinary(path);
  if (ExistsTextModel(path)) return ReadReconstructionText(path);
  throw InputError(path,
                   "no COLMAP model: expected cameras, images and points3D "
                   "files (.bin or .txt)");
}

void CheckReconstruction(const std::string& source,
                         const Reconstruction& reconstruction) {
  // Record by record against the records checked before, as the readers do.
  Reconstruction checked;
  for (const auto& [camera_id, camera] : reconstruction.cameras) {
    std::string problem = CameraRecordProblem(camera, checked);
    const int num_params = CameraModelNumParams(camera.model_id);
    if (problem.empty() &&
        static_cast<int>(camera.params.size()) != num_params) {
      problem = "camera " + std::to_string(camera_id) + ": camera model " +
                CameraModelIdToName(camera.model_id) + " has " +
                std::to_string(num_params) + " parameters (" +
                CameraModelParamsInfo(camera.model_id) + "), got " +
                std::to_string(camera.params.size());
    }
    if (!problem.empty()) throw InputError(source, problem);
    checked.cameras.emplace(camera_id, camera);
  }
  for (const auto& [image_id, image] : reconstruction.images) {
    const std::string problem = ImageRecordProblem(image, checked);
    if (!problem.empty()) throw InputError(source, problem);
    checked.images.emplace(image_id, Image());
  }
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    const std::string problem = PointRecordProblem(point3D_id, checked);
    if (!problem.empty()) throw InputError(source, problem);
    checked.points3D.emplace(point3D_id, Point3D());
  }
  CheckTracks(source, reconstruction);
}

// ---------------------------------------------------------------------------
// Statistics.

double MeanObservationsPerImage(const Reconstruction& reconstruction) {
  if (reconstruction.images.empty()) return 0.0;
  return NumObservations(reconstruction) /
         static_cast<double>(reconstruction.images.size());
}

// ---------------------------------------------------------------------------
// Writing.

std::string CamerasBinaryBytes(const Reconstruction& reconstruction) {
  std::string out;
  AppendBinary<uint64_t>(reconstruction.cameras.size(), &out);
  for (const auto& [camera_id, camera] : reconstruction.cameras) {
    CHECK(CameraHasValidParams(camera)) << "camera " << camera_id;
    AppendBinary<uint32_t>(camera_id, &out);
    AppendBinary<int32_t>(camera.model_id, &out);
    AppendBinary<uint64_t>(camera.width, &out);
    AppendBinary<uint64_t>(camera.height, &out);
    for (const double param : camera.params) AppendBinary<double>(param, &out);
  }
  return out;
}

std::string ImagesBinaryBytes(const Reconstruction& reconstruction) {
  std::string out;
  AppendBinary<uint64_t>(reconstruction.images.size(), &out);
  for (const auto& [image_id, image] : reconstruction.images) {
    CHECK(reconstruction.cameras.count(image.camera_id))
        << "image " << image_id << " has no camera";
    AppendBinary<uint32_t>(image_id, &out);
    const Eigen::Vector4d q = WrittenQuaternion(image);
    for (int k = 0; k < 4; ++k) AppendBinary<double>(q(k), &out);
    for (int k = 0; k < 3; ++k) {
      AppendBinary<double>(image.cam_from_world.translation(k), &out);
    }
    AppendBinary<uint32_t>(image.camera_id, &out);
    out.append(image.name);
    out.push_back('\0');
    AppendBinary<uint64_t>(image.points2D.size(), &out);
    for (const Point2D& point2D : image.points2D) {
      AppendBinary<double>(point2D.xy.x(), &out);
      AppendBinary<double>(point2D.xy.y(), &out);
      AppendBinary<uint64_t>(point2D.point3D_id, &out);
    }
  }
  return out;
}

std::string Points3DBinaryBytes(const Reconstruction& reconstruction) {
  std::string out;
  AppendBinary<uint64_t>(reconstruction.points3D.size(), &out);
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    AppendBinary<uint64_t>(point3D_id, &out);
    for (int k = 0; k < 3; ++k) AppendBinary<double>(point.xyz(k), &out);
    for (int k = 0; k < 3; ++k) AppendBinary<uint8_t>(point.color(k), &out);
    AppendBinary<double>(point.error, &out);
    AppendBinary<uint64_t>(point.track.size(), &out);
    for (const TrackElement& element : point.track) {
      AppendBinary<uint32_t>(element.image_id, &out);
      AppendBinary<uint32_t>(element.point2D_idx, &out);
    }
  }
  return out;
}

std::string CamerasTextBytes(const Reconstruction& reconstruction) {
  std::ostringstream out = MakeTextStream();
  out << "# Camera list with one line of data per camera:\n"
      << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      << "# Number of cameras: " << reconstruction.cameras.size() << "\n";
  for (const auto& [camera_id, camera] : reconstruction.cameras) {
    CHECK(CameraHasValidParams(camera)) << "camera " << camera_id;
    out << camera_id << " " << CameraModelIdToName(camera.model_id) << " "
        << camera.width << " " << camera.height;
    for (const double param : camera.params) out << " " << param;
    out << "\n";
  }
  return out.str();
}

std::string ImagesTextBytes(const Reconstruction& reconstruction) {
  std::ostringstream out = MakeTextStream();
  out << "# Image list with two lines of data per image:\n"
      << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      << "# Number of images: " << reconstruction.images.size()
      << ", mean observations per image: "
      << MeanObservationsPerImage(reconstruction) << "\n";
  for (const auto& [image_id, image] : reconstruction.images) {
    CHECK(reconstruction.cameras.count(image.camera_id))
        << "image " << image_id << " has no camera";
    const std::string name_problem = TextImageNameProblem(image.name);
    if (!name_problem.empty()) {
      throw InputError("image " + std::to_string(image_id),
                       name_problem + "; write the model as BIN instead");
    }
    const Eigen::Vector4d q = WrittenQuaternion(image);
    const Eigen::Vector3d& t = image.cam_from_world.translation;
    out << image_id << " " << q(0) << " " << q(1) << " " << q(2) << " " << q(3)
        << " " << t.x() << " " << t.y() << " " << t.z() << " "
        << image.camera_id << " " << image.name << "\n";
    for (size_t i = 0; i < image.points2D.size(); ++i) {
      const Point2D& point2D = image.points2D[i];
      if (i > 0) out << " ";
      out << point2D.xy.x() << " " << point2D.xy.y() << " ";
      if (point2D.point3D_id == kInvalidPoint3DId) {
        out << -1;
      } else {
        out << point2D.point3D_id;
      }
    }
    out << "\n";
  }
  return out.str();
}

std::string Points3DTextBytes(const Reconstruction& reconstruction) {
  std::ostringstream out = MakeTextStream();
  out << "# 3D point list with one line of data per point:\n"
      << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, "
         "POINT2D_IDX)\n"
      << "# Number of points: " << reconstruction.points3D.size()
      << ", mean track length: " << MeanTrackLength(reconstruction) << "\n";
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    out << point3D_id << " " << point.xyz.x() << " " << point.xyz.y() << " "
        << point.xyz.z() << " " << static_cast<int>(point.color(0)) << " "
        << static_cast<int>(point.color(1)) << " "
        << static_cast<int>(point.color(2)) << " " << point.error;
    // COLMAP ends a point with an empty track with the separator.
    if (point.track.empty()) out << " ";
    for (const TrackElement& element : point.track) {
      out << " " << element.image_id << " " << element.point2D_idx;
    }
    out << "\n";
  }
  return out.str();
}

std::string TextImageNameProblem(const std::string& name) {
  if (name.empty()) return "empty image name cannot be written to images.txt";
  for (const char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      return "image name '" + name +
             "' holds a control character (newline, tab, ...) that "
             "images.txt cannot hold";
    }
  }
  if (name.front() == ' ' || name.back() == ' ') {
    return "image name '" + name +
           "' starts or ends with a space, which images.txt loses";
  }
  return "";
}

void WriteReconstructionBinary(const Reconstruction& reconstruction,
                               const std::string& path) {
  ThrowIfNonFinite(path, reconstruction, "; not written");
  WriteFilesAtomically(path,
                       {{"cameras.bin", CamerasBinaryBytes(reconstruction)},
                        {"images.bin", ImagesBinaryBytes(reconstruction)},
                        {"points3D.bin", Points3DBinaryBytes(reconstruction)}});
}

void WriteReconstructionText(const Reconstruction& reconstruction,
                             const std::string& path) {
  ThrowIfNonFinite(path, reconstruction, "; not written");
  WriteFilesAtomically(path,
                       {{"cameras.txt", CamerasTextBytes(reconstruction)},
                        {"images.txt", ImagesTextBytes(reconstruction)},
                        {"points3D.txt", Points3DTextBytes(reconstruction)}});
}

void WriteReconstruction(const Reconstruction& reconstruction,
                         const std::string& path,
                         const std::string& output_type) {
  std::string type = output_type;
  std::transform(type.begin(), type.end(), type.begin(),
                 [](unsigned char c) { return std::toupper(c); });
  if (type == "BIN") {
    WriteReconstructionBinary(reconstruction, path);
  } else if (type == "TXT") {
    WriteReconstructionText(reconstruction, path);
  } else {
    throw InputError("output_type",
                     "must be BIN or TXT, got '" + output_type + "'");
  }
}

}  // namespace colmap_irav4
