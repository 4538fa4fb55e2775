// Camera models from every archive label: PDS3 as MER writes it (GEOMETRIC_CAMERA_MODEL) and as MSL and
// Mars 2020 write it (GEOMETRIC_CAMERA_MODEL_PARMS, the CAHVORE type and parameter as components 8 and 9),
// VICAR (the real MER frames' embedded VICAR label through GDAL must give what their PDS3 label gives) and
// VICAR and PDS4 files that GDAL writes here with the model in the label as the missions put it, read back
// with their pixels.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <cpl_conv.h>
#include <gdal.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/GdalLabel.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"
#include "tests/ground/io/GdalTestFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// A Mars 2020 Navcam CAHVORE (the real left model of NLF_0395_0702014201, rover navigation frame).
CameraModel navcam() {
  CameraModel m;
  m.type = CameraType::kCahvore;
  m.c = Vec3(0.938897, 0.34155, -1.89784);
  m.a = Vec3(0.838505, -0.0197104, 0.544552);
  m.h = Vec3(1125.57, 1453.18, 701.64);
  m.v = Vec3(9.27146, 5.19882, 1769.2);
  m.o = Vec3(0.838484, -0.0182928, 0.544633);
  m.r = Vec3(1.736e-06, 0.0501396, -0.0171254);
  m.e = Vec3(-8e-09, 1e-08, -2.9e-08);
  m.cahvore_kind = CahvoreKind::kFisheye;
  m.linearity = 0.0;
  m.width = 64;
  m.height = 48;
  return m;
}

std::string labelTuple(const Vec3& v) {
  char b[128];
  std::snprintf(b, sizeof b, "(%.9g,%.9g,%.9g)", v.x(), v.y(), v.z());
  return b;
}

void checkSameModel(const CameraModel& a, const CameraModel& b, double tol) {
  CHECK(a.type == b.type);
  CHECK((a.c - b.c).norm() < tol && (a.a - b.a).norm() < tol && (a.h - b.h).norm() < tol * 1e3);
  CHECK((a.v - b.v).norm() < tol * 1e3 && (a.o - b.o).norm() < tol && (a.r - b.r).norm() < tol);
  if (a.type == CameraType::kCahvore) {
    CHECK((a.e - b.e).norm() < tol);
    CHECK(a.cahvore_kind == b.cahvore_kind);
    DOUBLES_EQUAL(a.linearity, b.linearity, 1e-12);
  }
}

// A PDS3 camera group as MSL and Mars 2020 labels write it (component ids C..E, type and parameter as
// components 8 and 9, the model's frame and its site/drive index).
std::string parmsLabel(const CameraModel& m, bool ids_name_type) {
  std::string t =
      "PDS_VERSION_ID = PDS3\nINSTRUMENT_HOST_ID = M20\nINSTRUMENT_ID = \"NAVCAM_LEFT\"\n"
      "PRODUCT_ID = \"NLF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J01\"\n"
      "PLANET_DAY_NUMBER = 395\nSPACECRAFT_CLOCK_START_COUNT = \"702014201.641\"\n"
      "ROVER_MOTION_COUNTER = (17,1064,0,0,0,0,0,0,0,0)\n"
      "ROVER_MOTION_COUNTER_NAME = (\"SITE\",\"DRIVE\",\"POSE\",\"ARM\",\"CHIMRA\",\"DRILL\",\"RSM\",\n"
      "   \"HGA\",\"BITCAROUSEL\",\"SEAL\")\n"
      "GROUP = ROVER_COORDINATE_SYSTEM_PARMS\n  COORDINATE_SYSTEM_NAME = ROVER_NAV_FRAME\n"
      "  ORIGIN_OFFSET_VECTOR = (-21.1874,-196.367,-6.30818)\n"
      "  ORIGIN_ROTATION_QUATERNION = (0.60998,0.00355556,0.0310792,-0.791799)\n"
      "  REFERENCE_COORD_SYSTEM_NAME = SITE_FRAME\nEND_GROUP = ROVER_COORDINATE_SYSTEM_PARMS\n"
      "GROUP = GEOMETRIC_CAMERA_MODEL_PARMS\n  ^MODEL_DESC = \"GEOMETRIC_CM.TXT\"\n"
      "  FILTER_NAME = \"UNK\"\n  MODEL_TYPE = CAHVORE\n";
  t += ids_name_type ? "  MODEL_COMPONENT_ID = (\"C\",\"A\",\"H\",\"V\",\"O\",\"R\",\"E\",\"T\",\"P\")\n"
                     : "  MODEL_COMPONENT_ID = (\"C\",\"A\",\"H\",\"V\",\"O\",\"R\",\"E\")\n";
  t += "  MODEL_COMPONENT_NAME = (\"CENTER\",\"AXIS\",\"HORIZONTAL\",\"VERTICAL\",\"OPTICAL\",\"RADIAL\",\n"
       "    \"ENTRANCE\")\n";
  const Vec3* v[] = {&m.c, &m.a, &m.h, &m.v, &m.o, &m.r, &m.e};
  for (int k = 0; k < 7; ++k)
    t += "  MODEL_COMPONENT_" + std::to_string(k + 1) + " = " + labelTuple(*v[k]) + "\n";
  t += "  MODEL_COMPONENT_8 = 2.0\n  MODEL_COMPONENT_9 = 0.0\n"
       "  REFERENCE_COORD_SYSTEM_NAME = ROVER_NAV_FRAME\n"
       "  COORDINATE_SYSTEM_INDEX_NAME = (\"SITE\",\"DRIVE\",\"POSE\")\n"
       "  REFERENCE_COORD_SYSTEM_INDEX = (17,1064,0)\n"
       "END_GROUP = GEOMETRIC_CAMERA_MODEL_PARMS\nOBJECT = IMAGE\n  LINES = 968\n  LINE_SAMPLES = 1288\n"
       "END_OBJECT = IMAGE\nEND\n";
  return t;
}

}  // namespace

TEST_GROUP(ArchiveLabels){};

// MSL / Mars 2020 GEOMETRIC_CAMERA_MODEL_PARMS, with the type and parameter listed as T, P or only as
// components 8 and 9 (a reader that stops at the listed ids would take a perspective model): the fisheye
// model, its frame, and the label's rover pose, site, drive, sol, clock and instrument.
TEST(ArchiveLabels, Pds3ParmsAsMslAndMars2020WriteIt) {
  const CameraModel truth = navcam();
  for (bool ids_name_type : {true, false}) {
    const io::CameraFile f = io::parseCameraText(parmsLabel(truth, ids_name_type), "NLF.LBL");
    checkSameModel(f.model, truth, 1e-8);
    CHECK_EQUAL(1288, f.model.width);
    STRCMP_EQUAL("ROVER_NAV_FRAME", f.reference_frame.c_str());
    CHECK(f.reference_frame_stated);
    const io::Acquisition& a = f.acquisition;
    CHECK(a.mission == io::Mission::kM2020);
    STRCMP_EQUAL("NAVCAM_LEFT", a.instrument.c_str());
    CHECK_EQUAL(395, *a.sol);
    CHECK_EQUAL(17, *a.site);
    CHECK_EQUAL(1064, *a.drive);
    DOUBLES_EQUAL(702014201.641, *a.sclk_s, 1e-6);
    STRCMP_EQUAL("ROVER_NAV_FRAME", a.rover_frame.c_str());
    DOUBLES_EQUAL(-0.791799, (*a.attitude)(3), 1e-5);
    DOUBLES_EQUAL(-196.367, a.xyz_m->y(), 1e-9);
  }
}

// A counter the label cannot hold as a whole number (beyond int's range, fractional, not finite) is refused
// with the file and field named, never narrowed.
TEST(ArchiveLabels, CountersOutOfRangeAreRefused) {
  const std::string good = parmsLabel(navcam(), true);
  const struct {
    const char* from;
    const char* to;
    const char* field;
  } cases[] = {{"(17,1064,", "(1e300,1064,", "ROVER_MOTION_COUNTER (SITE)"},
               {"(17,1064,", "(17,-3e12,", "ROVER_MOTION_COUNTER (DRIVE)"},
               {"(17,1064,", "(17.5,1064,", "ROVER_MOTION_COUNTER (SITE)"},
               {"PLANET_DAY_NUMBER = 395", "PLANET_DAY_NUMBER = 9e99", "PLANET_DAY_NUMBER"}};
  for (const auto& c : cases) {
    std::string text = good;
    const std::size_t at = text.find(c.from);
    CHECK(at != std::string::npos);
    text.replace(at, std::string(c.from).size(), c.to);
    try {
      io::parseCameraText(text, "NLF.LBL");
      FAIL("a counter out of range was accepted");
    } catch (const cli::InputError& e) {
      const std::string what = e.what();
      CHECK(what.find("NLF.LBL") != std::string::npos);
      CHECK(what.find(c.field) != std::string::npos);
    }
  }
}

// The real MER frames: the embedded VICAR label (through GDAL's VICAR driver) gives the same model, frame,
// rover pose and counters as the attached PDS3 label; a MER label's site and drive come from
// ROVER_MOTION_COUNTER.
TEST(ArchiveLabels, MerVicarEqualsPds3) {
  if (!test::requireSharedData("mer-opportunity-navcam-sol4087")) return;
  for (const char* name : {"1N491020376ILFCNY9P0706L0M1.IMG", "1N491020519ILFCNY9P0706L0M1.IMG"}) {
    const std::string path = test::sharedDataDir() + "/mer-opportunity-navcam-sol4087/" + name;
    const io::CameraFile pds3 = io::readCameraFile(path);
    const io::CameraFile vicar = io::readVicarCamera(path);
    CHECK(pds3.format == io::CameraFileFormat::kPds3);
    CHECK(vicar.format == io::CameraFileFormat::kVicar);
    checkSameModel(vicar.model, pds3.model, 1e-12);
    CHECK_EQUAL(pds3.model.width, vicar.model.width);
    CHECK_EQUAL(1024, vicar.model.height);
    STRCMP_EQUAL("ROVER_FRAME", vicar.reference_frame.c_str());
    STRCMP_EQUAL(pds3.reference_frame.c_str(), vicar.reference_frame.c_str());
    const io::Acquisition &p = pds3.acquisition, &v = vicar.acquisition;
    CHECK(p.mission == io::Mission::kMer && v.mission == io::Mission::kMer);
    CHECK_EQUAL(195, *p.site);
    CHECK_EQUAL(973, *p.drive);
    CHECK_EQUAL(*p.site, *v.site);
    CHECK_EQUAL(*p.drive, *v.drive);
    CHECK_EQUAL(4087, *v.sol);
    STRCMP_EQUAL(p.product_id.c_str(), v.product_id.c_str());
    STRCMP_EQUAL("NAVCAM_LEFT", v.instrument.c_str());
    DOUBLES_EQUAL(*p.sclk_s, *v.sclk_s, 1e-6);
    CHECK((*p.attitude - *v.attitude).norm() < 1e-9);
    CHECK((*p.xyz_m - *v.xyz_m).norm() < 1e-9);
    // The pixels through GDAL: 12-bit data in 16-bit words scaled by 255 / 4095, as the PDS3 reader does.
    const cv::Mat a = io::readGdalImage8(path), b = io::readPds3Image8(io::readPds3ImageInfo(path));
    CHECK_EQUAL(b.cols, a.cols);
    double worst = 0.0;
    cv::minMaxLoc(cv::abs(a - b) + cv::abs(b - a), nullptr, &worst);
    CHECK(worst <= 1.0);
  }
}

// A VICAR file written by GDAL with the model as a PROPERTY GEOMETRIC_CAMERA_MODEL (components 1..9, the
// type and parameter 8 and 9) and IDENTIFICATION / ROVER_COORDINATE_SYSTEM properties: read back through
// readCameraFile (told by its content), with its 16-bit pixels by the 12-bit rule.
TEST(ArchiveLabels, VicarWrittenByGdal) {
  const CameraModel truth = navcam();
  const nlohmann::json label = test::vicarLabel(
      truth, "NAVCAM_RIGHT", "NRF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J01", "ROVER_NAV_FRAME");
  const std::string path = test::scratchDir("vicar-written") + "/NRF.VIC";
  const cv::Mat img = test::rampImage(64, 48, CV_16U, 4000.0);
  test::writeWithGdal(path, "VICAR", img, "json:VICAR", label.dump());
  CHECK(io::isGdalLabelFile(path));
  const io::CameraFile f = io::readCameraFile(path);
  CHECK(f.format == io::CameraFileFormat::kVicar);
  checkSameModel(f.model, truth, 1e-12);
  CHECK_EQUAL(64, f.model.width);
  CHECK_EQUAL(48, f.model.height);
  STRCMP_EQUAL("ROVER_NAV_FRAME", f.reference_frame.c_str());
  CHECK_EQUAL(17, *f.acquisition.site);
  CHECK_EQUAL(1064, *f.acquisition.drive);
  STRCMP_EQUAL("NAVCAM_RIGHT", f.acquisition.instrument.c_str());
  DOUBLES_EQUAL(0.60998, (*f.acquisition.attitude)(0), 1e-5);
  CHECK_EQUAL(0, test::runTool("areomap-camera", "'" + path + "' --json"));
  const cv::Mat grey = io::readGdalImage8(path);
  for (int y = 0; y < 48; y += 7) {
    for (int x = 0; x < 64; x += 5) {
      DOUBLES_EQUAL(std::round(img.at<uint16_t>(y, x) * 255.0 / 4095.0), grey.at<uint8_t>(y, x), 0.0);
    }
  }
}

// A PDS4 product written by GDAL from its own template with a geom:Geometry block in the Discipline_Area
// (geom:Camera_Model_Parameters / geom:CAHVORE_Model as the Mars 2020 PDS4 labels carry it): the model, its
// type, parameter and frame, and the 8-bit pixels as written.
TEST(ArchiveLabels, Pds4WrittenByGdal) {
  GDALAllRegister();
  const char* found = CPLFindFile("gdal", "pds4_template.xml");
  if (found == nullptr) {
    std::printf("SKIP: GDAL's pds4_template.xml not found\n");
    return;
  }
  std::ifstream in(found);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string tmpl = buffer.str();
  const CameraModel truth = navcam();
  auto vec = [](const char* element, const char* axis, const Vec3& v) {
    char b[512];
    std::snprintf(
        b, sizeof b,
        "<geom:%s><geom:x_%s>%.12g</geom:x_%s><geom:y_%s>%.12g</geom:y_%s><geom:z_%s>%.12g</geom:z_%s>"
        "</geom:%s>\n",
        element, axis, v.x(), axis, axis, v.y(), axis, axis, v.z(), axis, element);
    return std::string(b);
  };
  auto terms = [](const char* element, const Vec3& v) {
    char b[384];
    std::snprintf(
        b, sizeof b,
        "<geom:%s><geom:c0>%.12g</geom:c0><geom:c1>%.12g</geom:c1><geom:c2>%.12g</geom:c2></geom:%s>\n",
        element, v.x(), v.y(), v.z(), element);
    return std::string(b);
  };
  const std::string geom =
      "<geom:Geometry><geom:Geometry_Lander><geom:geometry_state>Telemetry</geom:geometry_state>\n"
      "<geom:Camera_Model_Parameters><geom:model_type>CAHVORE</geom:model_type>\n"
      "<geom:Coordinate_Space_Reference><geom:Coordinate_Space_Present>"
      "<geom:coordinate_space_frame_type>ROVER_NAV_FRAME</geom:coordinate_space_frame_type>"
      "</geom:Coordinate_Space_Present></geom:Coordinate_Space_Reference>\n<geom:CAHVORE_Model>\n" +
      vec("Vector_Center", "position", truth.c) + vec("Vector_Axis", "unit", truth.a) +
      vec("Vector_Horizontal", "pixel", truth.h) + vec("Vector_Vertical", "pixel", truth.v) +
      vec("Vector_Optical", "unit", truth.o) + terms("Radial_Terms", truth.r) +
      terms("Entrance_Terms", truth.e) +
      "<geom:cahvore_model_type>2</geom:cahvore_model_type>"
      "<geom:cahvore_model_parameter>0.0</geom:cahvore_model_parameter>\n"
      "</geom:CAHVORE_Model></geom:Camera_Model_Parameters></geom:Geometry_Lander></geom:Geometry>\n";
  const std::size_t da = tmpl.find("<Discipline_Area>");
  CHECK(da != std::string::npos);
  tmpl.insert(da + std::string("<Discipline_Area>").size(), "\n" + geom);
  const std::size_t ns = tmpl.find("xmlns:pds=");
  tmpl.insert(ns, "xmlns:geom=\"http://pds.nasa.gov/pds4/geom/v1\" ");
  const std::string dir = test::scratchDir("pds4-written");
  std::ofstream(dir + "/template.xml") << tmpl;
  const std::string option = "TEMPLATE=" + dir + "/template.xml";
  const char* const options[] = {
      option.c_str(),
      "VAR_LOGICAL_IDENTIFIER=urn:nasa:pds:test:data:nlf",
      "VAR_TITLE=NLF",
      "VAR_INVESTIGATION_AREA_NAME=Mars 2020",
      "VAR_INVESTIGATION_AREA_LID_REFERENCE=urn:nasa:pds:context:investigation:mission.mars2020",
      "VAR_OBSERVING_SYSTEM_NAME=NAVCAM_LEFT",
      "VAR_TARGET=Mars",
      "VAR_TARGET_TYPE=Planet",
      nullptr};
  const cv::Mat img = test::rampImage(64, 48, CV_8U, 250.0);
  const std::string path = dir + "/NLF.xml";
  test::writeWithGdal(path, "PDS4", img, nullptr, "", options);
  CHECK(io::isGdalLabelFile(path));
  const io::CameraFile f = io::readCameraFile(path);
  CHECK(f.format == io::CameraFileFormat::kPds4);
  checkSameModel(f.model, truth, 1e-10);
  CHECK_EQUAL(64, f.model.width);
  CHECK_EQUAL(48, f.model.height);
  STRCMP_EQUAL("ROVER_NAV_FRAME", f.reference_frame.c_str());
  CHECK_EQUAL(0, test::runTool("areomap-camera", "'" + path + "' --json"));
  const cv::Mat grey = io::readGdalImage8(path);
  CHECK_EQUAL(0, cv::countNonZero(grey != img));
}
