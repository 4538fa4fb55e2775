// Test helpers: VICAR and PDS4 files written with GDAL, a VICAR label carrying a camera model as the
// missions write it (PROPERTY GEOMETRIC_CAMERA_MODEL, IDENTIFICATION, ROVER_COORDINATE_SYSTEM), test pixels.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <gdal.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"

#include <CppUTest/TestHarness.h>

namespace areomap::test {

struct Closer {
  void operator()(void* ds) const {
    if (ds) GDALClose(ds);
  }
};

inline cv::Mat rampImage(int w, int h, int depth, double top) {
  cv::Mat img(h, w, depth);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double v = top * ((x * 7 + y * 13) % 97) / 96.0;
      if (depth == CV_8U)
        img.at<uint8_t>(y, x) = static_cast<uint8_t>(v);
      else
        img.at<uint16_t>(y, x) = static_cast<uint16_t>(v);
    }
  }
  return img;
}

// Writes `img` with GDAL's `driver` and the label set through SetMetadata(label, domain) before the pixels
// (or the TEMPLATE creation option for PDS4).
inline void writeWithGdal(const std::string& path, const char* driver, const cv::Mat& img, const char* domain,
                          const std::string& label, const char* const* options = nullptr) {
  GDALAllRegister();
  GDALDriverH d = GDALGetDriverByName(driver);
  CHECK(d != nullptr);
  const GDALDataType type = img.depth() == CV_8U ? GDT_Byte : GDT_UInt16;
  // VICAR's 16-bit words (HALF) are signed: 12-bit data fit.
  const GDALDataType stored = type == GDT_UInt16 && std::string(driver) == "VICAR" ? GDT_Int16 : type;
  std::unique_ptr<void, Closer> ds(
      GDALCreate(d, path.c_str(), img.cols, img.rows, 1, stored, const_cast<char**>(options)));
  CHECK(ds != nullptr);
  if (domain != nullptr) {
    const char* md[] = {label.c_str(), nullptr};
    CHECK(GDALSetMetadata(ds.get(), const_cast<char**>(md), domain) == CE_None);
  }
  cv::Mat data = img.clone();
  CHECK(GDALRasterIO(GDALGetRasterBand(ds.get(), 1), GF_Write, 0, 0, img.cols, img.rows, data.data, img.cols,
                     img.rows, type, 0, 0) == CE_None);
}

// The json:VICAR label of an M2020 frame at site 17, drive 1064 (the real sol-395 pose) with `model` (type
// and parameter as components 8 and 9) in `frame`.
inline nlohmann::json vicarLabel(const CameraModel& model, const std::string& instrument,
                                 const std::string& product_id, const std::string& frame, int site = 17,
                                 int drive = 1064) {
  nlohmann::json cm{{"MODEL_TYPE", "CAHVORE"},
                    {"MODEL_COMPONENT_ID", {"C", "A", "H", "V", "O", "R", "E"}},
                    {"REFERENCE_COORD_SYSTEM_NAME", frame},
                    {"MODEL_COMPONENT_8", static_cast<double>(static_cast<int>(model.cahvore_kind))},
                    {"MODEL_COMPONENT_9", model.linearity}};
  const Vec3* v[] = {&model.c, &model.a, &model.h, &model.v, &model.o, &model.r, &model.e};
  for (int k = 0; k < 7; ++k)
    cm["MODEL_COMPONENT_" + std::to_string(k + 1)] = {v[k]->x(), v[k]->y(), v[k]->z()};
  return nlohmann::json{{"PROPERTY",
                         {{"IDENTIFICATION",
                           {{"INSTRUMENT_HOST_ID", "M20"},
                            {"INSTRUMENT_ID", instrument},
                            {"PRODUCT_ID", product_id},
                            {"PLANET_DAY_NUMBER", 395},
                            {"SPACECRAFT_CLOCK_START_COUNT", "702014201.641"},
                            {"ROVER_MOTION_COUNTER", {site, drive}},
                            {"ROVER_MOTION_COUNTER_NAME", {"SITE", "DRIVE"}}}},
                          {"ROVER_COORDINATE_SYSTEM",
                           {{"COORDINATE_SYSTEM_NAME", "ROVER_NAV_FRAME"},
                            {"ORIGIN_OFFSET_VECTOR", {-21.1874, -196.367, -6.30818}},
                            {"ORIGIN_ROTATION_QUATERNION", {0.60998, 0.00355556, 0.0310792, -0.791799}}}},
                          {"GEOMETRIC_CAMERA_MODEL", cm}}}};
}

}  // namespace areomap::test
