// report.html in a real browser: headless Chromium (Debian's `chromium`) loads the page,
// a probe script appended to a copy counts images that failed to load or decode, and a screenshot must not
// be blank. The detector itself is checked on a page with a missing image. Skips (with a line saying so)
// when chromium is not installed.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/products/Previews.hpp"
#include "ground/products/ReportHtml.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

const char* kProbe =
    "<script>window.addEventListener('load',function(){var b=0,n=0;for(const i of document.images){n++;"
    "if(!i.complete||i.naturalWidth===0)b++;}var d=document.createElement('div');d.id='areomap-probe';"
    "d.textContent='probe images='+n+' broken='+b+' svg='+document.querySelectorAll('svg').length+' end';"
    "document.body.appendChild(d);});</script>\n";

std::string chromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (std::filesystem::exists(p)) return p;
  }
  return "";
}

std::string run(const std::string& command) {
  std::string out;
  FILE* f = popen(command.c_str(), "r");
  if (f == nullptr) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, f)) > 0) out.append(buf, n);
  pclose(f);
  return out;
}

std::string flags(const std::string& profile) {
  return " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking"
         " --disable-component-update --disable-sync --user-data-dir=" + profile + " ";
}

struct BrowserResult {
  int images = -1, broken = -1, svg = -1;
  double screenshot_stddev = 0.0;
  bool screenshot = false;
};

BrowserResult load(const std::string& html_path, const std::string& dir) {
  BrowserResult r;
  const std::string probe_path = dir + "/probe.html";
  {
    std::ifstream in(html_path);
    std::stringstream s;
    s << in.rdbuf();
    std::ofstream out(probe_path);
    out << s.str() << kProbe;
  }
  const std::string dom = run(chromium() + flags(dir + "/profile1") + "--virtual-time-budget=10000 --dump-dom file://" +
                              probe_path + " 2>/dev/null");
  const std::size_t at = dom.rfind("probe images=");  // the last: the script text holds it too
  if (at != std::string::npos) std::sscanf(dom.c_str() + at, "probe images=%d broken=%d svg=%d", &r.images, &r.broken, &r.svg);
  const std::string shot = dir + "/shot.png";
  run(chromium() + flags(dir + "/profile2") + "--window-size=1200,1600 --screenshot=" + shot + " file://" + html_path +
      " 2>/dev/null");
  const cv::Mat img = cv::imread(shot, cv::IMREAD_GRAYSCALE);
  if (!img.empty()) {
    r.screenshot = true;
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    r.screenshot_stddev = sd[0];
  }
  return r;
}

products::HtmlInputs sampleInputs() {
  products::HtmlInputs in;
  in.site = "test <site>";
  in.summary = {{"images", "2"}, {"dense points", "1234"}};
  for (int i = 0; i < 200; ++i) in.residuals_px.push_back(0.01 * (i % 37));
  in.image_rms_px = {{"p000_L", 0.21}, {"p000_R", 0.18}};
  DemGrid dem;
  dem.cols = 120;
  dem.rows = 90;
  dem.cell_m = 0.05;
  for (int r = 0; r < dem.rows; ++r)
    for (int c = 0; c < dem.cols; ++c) dem.values.push_back(static_cast<float>(0.3 * std::sin(c * 0.1) * std::cos(r * 0.07)));
  in.products.push_back({"DEM", products::demPreview(dem)});
  cv::Mat grey(80, 100, CV_8U);
  cv::randu(grey, 0, 255);
  in.overlays.push_back({"p000_L", products::tieOverlay(grey, {Vec2(10, 10), Vec2(50, 40)}, {false, true})});
  in.warnings = {"pair 3: no valid dense matches"};
  return in;
}

}  // namespace

TEST_GROUP(ReportHtml){};

TEST(ReportHtml, Base64MatchesKnownVectors) {
  auto b = [](const std::string& s) { return products::base64(std::vector<unsigned char>(s.begin(), s.end())); };
  STRCMP_EQUAL("", b("").c_str());
  STRCMP_EQUAL("Zg==", b("f").c_str());
  STRCMP_EQUAL("Zm8=", b("fo").c_str());
  STRCMP_EQUAL("Zm9v", b("foo").c_str());
  STRCMP_EQUAL("Zm9vYmFy", b("foobar").c_str());
}

TEST(ReportHtml, RendersInHeadlessChromium) {
  if (chromium().empty()) {
    std::printf("\n  SKIP: chromium not installed (apt-get install chromium)\n");
    return;
  }
  const std::string dir = test::scratchDir("report_html");
  const std::string page = dir + "/report.html";
  {
    std::ofstream out(page);
    out << products::reportHtml(sampleInputs());
  }
  const BrowserResult r = load(page, dir);
  std::printf("\n  report.html in chromium: %d images, %d broken, %d svg, screenshot stddev %.1f\n", r.images, r.broken,
              r.svg, r.screenshot_stddev);
  CHECK_EQUAL(2, r.images);
  CHECK_EQUAL(0, r.broken);
  CHECK_EQUAL(2, r.svg);
  CHECK(r.screenshot);
  CHECK(r.screenshot_stddev > 10.0);  // not a blank page

  // The detector sees a missing resource and a blank page.
  const std::string bad = dir + "/bad.html";
  {
    std::ofstream out(bad);
    out << "<!DOCTYPE html><html><body><img src='missing.png' alt=''></body></html>";
  }
  const BrowserResult b = load(bad, dir);
  CHECK_EQUAL(1, b.images);
  CHECK_EQUAL(1, b.broken);
  CHECK(b.screenshot_stddev < 2.0);
}
