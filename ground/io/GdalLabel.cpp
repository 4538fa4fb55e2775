#include "ground/io/GdalLabel.hpp"

#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <vector>

#include <cpl_conv.h>
#include <cpl_minixml.h>
#include <gdal.h>
#include <nlohmann/json.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFileParts.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"

namespace areomap::io {
namespace {

struct DatasetCloser {
  void operator()(void* ds) const {
    if (ds != nullptr) GDALClose(ds);
  }
};
using DatasetHandle = std::unique_ptr<void, DatasetCloser>;

// Opens `path` read-only with GDAL, the VICAR driver taking files that also have a PDS3 label.
DatasetHandle open(const std::string& path, const char* driver) {
  GDALAllRegister();
  CPLSetThreadLocalConfigOption("GDAL_TRY_PDS3_WITH_VICAR", "YES");
  const char* const drivers[] = {driver, nullptr};
  DatasetHandle ds(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, drivers, nullptr, nullptr));
  CPLSetThreadLocalConfigOption("GDAL_TRY_PDS3_WITH_VICAR", nullptr);
  if (!ds) throw cli::InputError(path, "file", std::string("GDAL's ") + driver + " driver cannot open it");
  return ds;
}

std::string firstMetadata(void* ds, const char* domain, const std::string& path) {
  char** md = GDALGetMetadata(ds, domain);
  if (md == nullptr || md[0] == nullptr) throw cli::InputError(path, domain, "GDAL gives no label");
  return md[0];
}

// One JSON value in PDS3 form: numbers as they are, strings quoted, arrays as "(a,b,c)".
std::string pds3Value(const nlohmann::json& v) {
  if (v.is_string()) return "\"" + v.get<std::string>() + "\"";
  if (v.is_array()) {
    std::string out = "(";
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? "," : "") + pds3Value(v[i]);
    return out + ")";
  }
  if (v.is_number()) {
    std::ostringstream s;
    s.precision(17);
    s << v.get<double>();
    return s.str();
  }
  return "\"\"";
}

// The VICAR label's properties as a PDS3 label text: each property a GROUP, the image size an IMAGE
// object, so that the PDS3 reader reads the same keywords.
std::string vicarAsPds3(const nlohmann::json& label) {
  std::string text = "PDS_VERSION_ID = PDS3\n";
  if (label.contains("PROPERTY") && label["PROPERTY"].is_object()) {
    for (const auto& group : label["PROPERTY"].items()) {
      if (!group.value().is_object()) continue;
      text += "GROUP = " + group.key() + "\n";
      for (const auto& item : group.value().items()) {
        if (item.value().is_object() || item.key().find("__") != std::string::npos) continue;
        text += "  " + item.key() + " = " + pds3Value(item.value()) + "\n";
      }
      text += "END_GROUP = " + group.key() + "\n";
    }
  }
  if (label.contains("NL") && label.contains("NS")) {
    text += "OBJECT = IMAGE\n  LINES = " + pds3Value(label["NL"]) +
            "\n  LINE_SAMPLES = " + pds3Value(label["NS"]) + "\nEND_OBJECT = IMAGE\n";
  }
  return text + "END\n";
}

void rasterSize(void* ds, CameraFile& out) {
  out.file_model.width = GDALGetRasterXSize(ds);
  out.file_model.height = GDALGetRasterYSize(ds);
  out.model.width = out.file_model.width;
  out.model.height = out.file_model.height;
  out.size_from_file = true;
}

// ---- PDS4 XML ----

struct XmlFree {
  void operator()(CPLXMLNode* n) const { CPLDestroyXMLNode(n); }
};

// The local name of an element ("geom:Vector_Center" -> "Vector_Center").
std::string localName(const CPLXMLNode* n) {
  const std::string name = n->pszValue;
  const std::size_t colon = name.find(':');
  return colon == std::string::npos ? name : name.substr(colon + 1);
}

const CPLXMLNode* findElement(const CPLXMLNode* n, const std::string& local) {
  for (; n != nullptr; n = n->psNext) {
    if (n->eType != CXT_Element) continue;
    if (localName(n) == local) return n;
    if (const CPLXMLNode* found = findElement(n->psChild, local)) return found;
  }
  return nullptr;
}

std::string textOf(const CPLXMLNode* n) {
  for (const CPLXMLNode* c = n->psChild; c != nullptr; c = c->psNext) {
    if (c->eType == CXT_Text) return c->pszValue;
  }
  return "";
}

// The three numeric child elements of a vector element, in order.
Vec3 vectorOf(const CPLXMLNode* model, const std::string& local, const std::string& path) {
  const CPLXMLNode* v = findElement(model->psChild, local);
  const std::string field = "geom:" + localName(model) + "/geom:" + local;
  if (v == nullptr) throw cli::InputError(path, field, "missing");
  std::vector<std::string> items;
  for (const CPLXMLNode* c = v->psChild; c != nullptr; c = c->psNext) {
    if (c->eType == CXT_Element) items.push_back(textOf(c));
  }
  return detail::parseVector(items, path, field);
}

}  // namespace

bool isGdalLabelFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  char head[512] = {};
  f.read(head, sizeof head - 1);
  const std::string text(head, static_cast<std::size_t>(f.gcount()));
  if (text.compare(0, 8, "LBLSIZE=") == 0) return true;
  return text.find("<?xml") != std::string::npos && text.find("pds.nasa.gov/pds4") != std::string::npos;
}

CameraFile readVicarCamera(const std::string& path, int width, int height) {
  const DatasetHandle ds = open(path, "VICAR");
  nlohmann::json label;
  try {
    label = nlohmann::json::parse(firstMetadata(ds.get(), "json:VICAR", path));
  } catch (const nlohmann::json::exception& e) {
    throw cli::InputError(path, "json:VICAR", e.what());
  }
  CameraFile out = detail::fromPds3(Pds3Label::parse(vicarAsPds3(label), path), width, height);
  out.format = CameraFileFormat::kVicar;
  rasterSize(ds.get(), out);
  if (out.acquisition.product_id.empty()) out.acquisition.product_id = pathStem(path);
  return out;
}

CameraFile readPds4Camera(const std::string& path, int width, int height) {
  (void)width;
  (void)height;
  const DatasetHandle ds = open(path, "PDS4");
  const std::unique_ptr<CPLXMLNode, XmlFree> root(
      CPLParseXMLString(firstMetadata(ds.get(), "xml:PDS4", path).c_str()));
  if (!root) throw cli::InputError(path, "xml:PDS4", "not well-formed XML");
  const CPLXMLNode* params = findElement(root.get(), "Camera_Model_Parameters");
  if (params == nullptr)
    throw cli::InputError(path, "geom:Camera_Model_Parameters", "the label has no camera model");
  CameraFile out;
  out.format = CameraFileFormat::kPds4;
  CameraModel& m = out.file_model;
  const CPLXMLNode* model = nullptr;
  for (const auto& [local, type] : {std::pair<const char*, CameraType>{"CAHVORE_Model", CameraType::kCahvore},
                                    {"CAHVOR_Model", CameraType::kCahvor},
                                    {"CAHV_Model", CameraType::kCahv}}) {
    if (model == nullptr && (model = findElement(params->psChild, local)) != nullptr) m.type = type;
  }
  if (model == nullptr) {
    throw cli::InputError(path, "geom:Camera_Model_Parameters",
                          "no geom:CAHVORE_Model, CAHVOR_Model or CAHV_Model");
  }
  m.c = vectorOf(model, "Vector_Center", path);
  m.a = vectorOf(model, "Vector_Axis", path);
  m.h = vectorOf(model, "Vector_Horizontal", path);
  m.v = vectorOf(model, "Vector_Vertical", path);
  if (m.type != CameraType::kCahv) {
    m.o = vectorOf(model, "Vector_Optical", path);
    m.r = vectorOf(model, "Radial_Terms", path);
  }
  if (m.type == CameraType::kCahvore) {
    m.e = vectorOf(model, "Entrance_Terms", path);
    const CPLXMLNode* type = findElement(model->psChild, "cahvore_model_type");
    const CPLXMLNode* parameter = findElement(model->psChild, "cahvore_model_parameter");
    if (type == nullptr) throw cli::InputError(path, "geom:cahvore_model_type", "missing");
    const double t = detail::parseNumber(textOf(type), path, "geom:cahvore_model_type");
    const double p =
        parameter ? detail::parseNumber(textOf(parameter), path, "geom:cahvore_model_parameter") : 1.0;
    detail::setKind(m, t, p, path, "geom:cahvore_model_type");
  }
  for (const char* frame_key : {"coordinate_space_frame_type", "reference_coord_system_name"}) {
    const CPLXMLNode* frame = findElement(params->psChild, frame_key);
    if (frame != nullptr && out.reference_frame.empty()) {
      out.reference_frame = textOf(frame);
      out.reference_frame_stated = true;
    }
  }
  if (const CPLXMLNode* id = findElement(root.get(), "logical_identifier")) {
    const std::string lid = textOf(id);
    out.acquisition.product_id = lid.substr(lid.rfind(':') + 1);
  }
  if (const CPLXMLNode* instrument = findElement(root.get(), "Observing_System_Component")) {
    if (const CPLXMLNode* name = findElement(instrument->psChild, "name"))
      out.acquisition.instrument = textOf(name);
  }
  out.model = m;
  rasterSize(ds.get(), out);
  detail::validateOrThrow(out.file_model, path,
                          [](const std::string& f) { return "geom:Camera_Model_Parameters (" + f + ")"; });
  out.model = out.file_model;
  return out;
}

cv::Mat readGdalImage8(const std::string& path) {
  GDALAllRegister();
  CPLSetThreadLocalConfigOption("GDAL_TRY_PDS3_WITH_VICAR", "YES");
  DatasetHandle ds(GDALOpen(path.c_str(), GA_ReadOnly));
  CPLSetThreadLocalConfigOption("GDAL_TRY_PDS3_WITH_VICAR", nullptr);
  if (!ds || GDALGetRasterCount(ds.get()) < 1)
    throw cli::InputError(path, "image", "GDAL cannot read its pixels");
  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);
  const int w = GDALGetRasterXSize(ds.get()), h = GDALGetRasterYSize(ds.get());
  cv::Mat values(h, w, CV_32F);
  if (GDALRasterIO(band, GF_Read, 0, 0, w, h, values.data, w, h, GDT_Float32, 0, 0) != CE_None) {
    throw cli::InputError(path, "image", "GDAL cannot read its pixels");
  }
  if (GDALGetRasterDataType(band) == GDT_Byte) {
    cv::Mat out;
    values.convertTo(out, CV_8U);
    return out;
  }
  return toGrey8(values);
}

}  // namespace areomap::io
