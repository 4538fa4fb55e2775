// areomap-ground: the ground node. See kUsage.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/node/EventRecorder.hpp"
#include "ground/node/GroundNode.hpp"
#include "ground/node/Manifest.hpp"
#include "ground/node/StreamTraverse.hpp"
#include "ground/pass/GroundPass.hpp"
#include "platform/TransportUrl.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/LcmTransport.hpp"

namespace {

constexpr const char* kUsage =
    "usage: areomap-ground --lcm URL --out DIR [--truth DATASET] [--traverse] [options]\n"
    "       areomap-ground --dataset DIR --out DIR [--truth DATASET]\n"
    "\n"
    "The ground node. With --lcm it subscribes to the camera stream (AREOMAP_STEREO_PAIR) and the rover's\n"
    "results (AREOMAP_TIEPOINTS, AREOMAP_EO_SOLUTION, AREOMAP_COARSE_DEM, AREOMAP_ROVER_STATUS), keeps the\n"
    "full-resolution images (DIR/stream/: images as decoded from the stream's JPEGs, models, "
    "panorama.json),\n"
    "and at the end-of-panorama marker (after waiting, bounded, for the rover's final EO) runs the ground\n"
    "pass, then publishes AREOMAP_PRODUCT (files, sizes, sha256) on the same URL. With --dataset it runs "
    "the\n"
    "same pass on a dataset folder, without LCM.\n"
    "\n"
    "The pass: the rover's tie points (AREOMAP_TIEPOINTS) when they arrived complete, else the rover's "
    "matcher\n"
    "run on the ground's images of any size (binned to its 1024x1024 capacity, every tie then matched\n"
    "again at full resolution) (report.json ground.tie_source, and a warning saying why); the fast "
    "adjustment\n"
    "(outlier rejection); a hold-out check (5-fold cross-validation of the tie points: wrong ties left out,\n"
    "a pair whose held-out ties the adjustment does not improve keeps its a-priori models, report.json\n"
    "adjustment_check); the integrated adjustment (Ceres) as the reference; products in DIR: "
    "models/<stem>.cahvor,\n"
    "eo.csv, tiepoints.csv, rover_models/<stem>.cahvor (the rover's last EO), rover_tiepoints.csv,\n"
    "report.json (method1/2/3,\n"
    "stream {pairs, gaps, duplicates, reordered, rejected}, rover {heap_allocs_after_init, static_bytes\n"
    "(static and start-up reserve), seconds_per_pair, eo_vs_ground_px}, truth, warnings naming gap-affected\n"
    "pairs).\n"
    "\n"
    "  --lcm URL           udpm://GROUP:PORT[?recv_buf_size=B] (live; recv_buf_size and ttl=0 added when\n"
    "                      absent), file://LOG (re-make products from a recorded pass; read at full speed)\n"
    "  --dataset DIR       a dataset folder (panorama.json), instead of --lcm\n"
    "  --out DIR           output folder (created)\n"
    "  --truth DATASET     a dataset folder with truth/ (true models): truth.eo_px in the report. With\n"
    "                      --dataset the dataset's own truth/ is used when present\n"
    "  --rover-wait-s S    after the end marker, wait up to S s for the rover's final EO (default 1800)\n"
    "  --rover-silent-s S  ... but stop waiting when the rover sent nothing for S s (default 300: a busy "
    "rover\n"
    "                      sends nothing while it works on a pair; 5 s when no rover was ever heard)\n"
    "  --idle-timeout-s S  the stream stops without an end marker: make products after S s (default 120)\n"
    "  --first-timeout-s S nothing arrives at all within S s: exit 1 (default 600)\n"
    "  --panoramas N       make products for N panoramas, then exit (default 1; 0 = until the stream ends):\n"
    "                      with N != 1 panorama k (1-based) goes to DIR/panorama-KKK/ (own stream/, report)\n"
    "  --traverse          a multi-site traverse (areomap-pack of a traverse.json): also subscribes to\n"
    "                      AREOMAP_SITE; each site's panorama (tied to its site by the panorama name the "
    "site\n"
    "                      announcement gives) is mapped into DIR/sites/<id>/ as it arrives, and after the\n"
    "                      last site the traverse steps of areomap-traverse run: DIR/traverse.json (the\n"
    "                      announced sites; their datasets DIR/sites/<id>/stream), poses.csv, models/<id>/,\n"
    "                      the merged dem.tif, dem_sigma.tif, ortho.tif and report.json (traverse.sites, "
    "...;\n"
    "                      `stream` counts the site announcements and what was refused: an announcement "
    "that\n"
    "                      does not decode or repeats a site, a pair whose panorama no site announced).\n"
    "                      --truth TRAVERSE: the traverse folder packed (truth/traverse.json, truth/dem.tif\n"
    "                      and each site's truth/)\n"
    "  --cross-ties FILE   with --traverse: cross-site tie points (CSV point,site,image,sample_px,line_px) "
    "for\n"
    "                      the multi-site adjustment of the poses, as areomap-traverse --cross-ties\n"
    "  --truth-cross-ties  with --traverse --truth TRAVERSE: cross-site ties from the synthetic traverse's "
    "truth\n"
    "                      with --noise-px S (default 0.3), as areomap-traverse --truth-cross-ties (a check "
    "of\n"
    "                      the adjustment, not a measurement)\n"
    "  --no-cross-ties     with --traverse: no cross-site matching (by default the received sites are\n"
    "                      matched as areomap-traverse does); the poses are the odometry's\n"
    "  --no-record         do not record: by default a live node (udpm://, memq://) appends every message "
    "it\n"
    "                      receives to DIR/received.lcm before handling it; after a crash or kill,\n"
    "                      `--lcm file://DIR/received.lcm` re-makes the same products\n"
    "  --no-products       adjustment products only (no dense matching, DEM, ortho, previews)\n"
    "  --no-rover-ties     always match the ground's images (ignore the rover's AREOMAP_TIEPOINTS)\n"
    "  --stream-only       collect and count the stream only (the `stream:` line), no pass, nothing written\n"
    "  --summary-json      print the figures as one JSON line on stdout at the end\n"
    "  --threads N         threads of the pass's parallel work (pairs, rows, cells; default: every core);\n"
    "                      the products are the same bytes for any N\n"
    "\n"
    "Exit: 0 ok, 2 usage error, 1 other error (the message names the file or URL and the field); also 1 when "
    "a\n"
    "product could not be written (full disk, folder not writable): every other product is still made, and "
    "each\n"
    "file not written is named on stderr.\n";

constexpr std::size_t kReplayBufferBytes = 16u * 1024u * 1024u;  // one log event: a stereo pair is <= ~4 MiB

void printSummary(const areomap::ground::GroundPassResult& p, std::size_t files, const std::string& out) {
  std::printf("ground: %d pairs, %d images, %d points, %d intra + %d inter observations, %d rejected\n",
              p.pairs, p.images, p.points, p.intra_observations, p.inter_observations,
              p.rejected_observations);
  std::printf(
      "ground: method 1 mean distance %.3f px before, %.3f px after (integrated, %d iterations); fast %.3f "
      "px "
      "(%d sweeps)\n",
      p.method1_before_px, p.method1_after_px, p.integrated_iterations, p.method1_fast_px, p.fast_sweeps);
  if (p.truth_eo_after_px) {
    std::printf("ground: truth EO error %.3f px before, %.3f px integrated, %.3f px fast (datum removed)\n",
                p.truth_eo_before_px.value_or(-1.0), *p.truth_eo_after_px, p.truth_eo_fast_px.value_or(-1.0));
  }
  if (p.rover_vs_ground_px) std::printf("ground: rover EO vs integrated %.4f px\n", *p.rover_vs_ground_px);
  std::printf("ground: %zu product files in %s\n", files, out.c_str());
}

// DESIGN.md exit codes: a product that could not be written (full disk, folder not writable) is an error,
// reported once every other product is made: each file named on stderr, then exit 1.
int writeErrorsExit(const std::vector<std::string>& errors) {
  if (errors.empty()) return 0;
  for (const std::string& e : errors)
    std::fprintf(stderr, "areomap-ground: error: not written: %s\n", e.c_str());
  std::fprintf(
      stderr,
      "areomap-ground: error: %zu product file(s) could not be written; the other products were made\n",
      errors.size());
  return 1;
}

using namespace areomap;

// The command line, checked.
struct GroundArgs {
  std::string out;
  std::optional<std::string> lcm, dataset_dir;
  ground::GroundNodeOptions options;
  bool summary_json = false;
  bool no_record = false;
  std::string cross_ties;
  bool truth_cross_ties = false;
  bool no_cross_ties = false;
  double noise_px = 0.3;
  std::string truth_traverse;  // --truth naming a traverse folder (with --traverse)
};

// --truth with --traverse names the traverse folder packed: each site's truth is its site folder.
void traverseTruth(GroundArgs& a) {
  ground::GroundNodeOptions& options = a.options;
  if (!options.traverse || options.pass.truth_dir.empty()) return;
  const std::string& t = options.pass.truth_dir;
  if (!std::filesystem::is_regular_file(t + "/" + kTraverseFileName)) {
    throw cli::InputError(t, "--truth",
                          std::string("with --traverse, a traverse folder with ") + kTraverseFileName);
  }
  a.truth_traverse = t;
  for (const TraverseSite& site : readTraverse(t).sites) options.site_truth_dirs[site.id] = site.dir;
  options.pass.truth_dir.clear();
}

GroundArgs parseArgs(cli::Args& args) {
  GroundArgs a;
  a.out = args.required("--out");
  a.lcm = args.option("--lcm");
  a.dataset_dir = args.option("--dataset");
  ground::GroundNodeOptions& options = a.options;
  options.pass.out_dir = a.out;
  options.pass.truth_dir = args.option("--truth", "");
  options.rover_wait_s = args.number("--rover-wait-s", 1800.0);
  options.rover_silent_s = args.number("--rover-silent-s", 300.0);
  options.idle_timeout_s = args.number("--idle-timeout-s", 120.0);
  options.first_message_timeout_s = args.number("--first-timeout-s", 600.0);
  a.summary_json = args.flag("--summary-json");
  cli::threadsOption(args);
  const double panoramas = args.number("--panoramas", 1.0);
  a.no_record = args.flag("--no-record");
  options.pass.products = !args.flag("--no-products");
  options.pass.use_rover_ties = !args.flag("--no-rover-ties");
  options.stream_only = args.flag("--stream-only");
  options.traverse = args.flag("--traverse");
  a.cross_ties = args.option("--cross-ties", "");
  a.truth_cross_ties = args.flag("--truth-cross-ties");
  a.no_cross_ties = args.flag("--no-cross-ties");
  a.noise_px = args.number("--noise-px", 0.3);
  args.finish();
  if (!(panoramas >= 0.0) || panoramas != static_cast<double>(static_cast<int32_t>(panoramas))) {
    throw cli::UsageError("--panoramas needs a whole number >= 0");
  }
  options.panoramas = static_cast<int32_t>(panoramas);
  if (a.lcm.has_value() == a.dataset_dir.has_value())
    throw cli::UsageError("give exactly one of --lcm URL and --dataset DIR");
  if (options.traverse && !a.lcm)
    throw cli::UsageError("--traverse needs --lcm (for a traverse folder: areomap-traverse)");
  if (!options.traverse && (a.truth_cross_ties || a.no_cross_ties || !a.cross_ties.empty()))
    throw cli::UsageError("--cross-ties, --truth-cross-ties and --no-cross-ties go with --traverse");
  if (int(a.truth_cross_ties) + int(a.no_cross_ties) + int(!a.cross_ties.empty()) > 1)
    throw cli::UsageError("give at most one of --cross-ties FILE, --truth-cross-ties and --no-cross-ties");
  traverseTruth(a);
  for (double v : {options.rover_wait_s, options.rover_silent_s, options.idle_timeout_s,
                   options.first_message_timeout_s}) {
    if (!(v >= 0.0)) throw cli::UsageError("timeouts must be >= 0 seconds");
  }
  return a;
}

// --dataset: the pass on a folder, without LCM.
int runOnDataset(const GroundArgs& a) {
  const Dataset dataset = readDataset(*a.dataset_dir);
  const ground::SitePass pass = ground::runGroundPass(dataset, a.options.pass, nullptr, nullptr);
  const std::size_t files = ground::buildManifest(a.out).size();
  std::printf("ground: ran on dataset %s (no LCM)\n", a.dataset_dir->c_str());
  printSummary(pass.summary, files, a.out);
  if (a.summary_json) {
    std::printf("{\"pairs\": %d, \"method1_before_px\": %.6f, \"method1_after_px\": %.6f, \"files\": %zu}\n",
                pass.summary.pairs, pass.summary.method1_before_px, pass.summary.method1_after_px, files);
  }
  return writeErrorsExit(pass.summary.write_errors);
}

// What the stream run gathers over its panoramas.
struct StreamRun {
  std::vector<std::string> write_errors;                                  // over every panorama
  std::map<std::string, std::shared_ptr<const ground::SitePass>> passes;  // traverse: by site id
};

// The figures of one panorama as it is done: the stream, the rover, and its pass when several are made.
void panoramaDone(const GroundArgs& a, const ground::GroundNodeResult& r, StreamRun& run) {
  int rejected = 0;
  for (const auto& [cause, count] : r.stream.rejected) rejected += count;
  std::printf(
      "stream: %d pairs, %d gaps, %d duplicates, %d reordered, %d rejected; %lld messages in %.2f s\n",
      r.stream.pairs, r.stream.gaps, r.stream.duplicates, r.stream.reordered, rejected,
      static_cast<long long>(r.messages), r.receive_seconds);
  if (r.rover.status) {
    const rover_status_t& st = *r.rover.status;
    std::printf(
        "rover: %d pairs seen, %d accepted, %d rejected, %d binned, %d sequence gaps; %d tie-point "
        "messages (%d lost); heap allocations after start-up %lld; final EO %s\n",
        st.pairs_seen, st.pairs_accepted, st.pairs_rejected, st.pairs_binned, st.sequence_gaps,
        r.rover.tie_messages, r.rover.tie_messages_missing, static_cast<long long>(st.heap_allocs_after_init),
        r.rover.finished ? "arrived" : "missing");
  }
  if (a.options.stream_only) return;
  const std::vector<std::string>& errors = r.pass.summary.write_errors;
  run.write_errors.insert(run.write_errors.end(), errors.begin(), errors.end());
  if (a.options.traverse) {
    run.passes[r.site_id] = std::make_shared<const ground::SitePass>(r.pass);
    std::printf("site %s: products in %s\n", r.site_id.c_str(), r.out_dir.c_str());
    printSummary(r.pass.summary, r.files.size(), r.out_dir);
  } else if (a.options.panoramas != 1) {
    std::printf("panorama %d: products in %s\n", r.panorama_index, r.out_dir.c_str());
    printSummary(r.pass.summary, r.files.size(), r.out_dir);
  }
  std::fflush(stdout);
}

// Receives from the URL (a log replayed, or live with the recording) and makes each panorama's products.
ground::GroundNodeResult receive(GroundArgs& a, StreamRun& run) {
  ground::GroundNodeOptions& options = a.options;
  const ground::PanoramaDone done = [&](const ground::GroundNodeResult& r) { panoramaDone(a, r, run); };
  ground::GroundNodeResult result;
  if (platform::urlScheme(a.lcm->c_str()) == platform::UrlScheme::kFile) {
    std::vector<uint8_t> buffer(kReplayBufferBytes);
    platform::LcmLogReplay replay(buffer.data(), buffer.size());
    if (!ok(replay.open(a.lcm->c_str()))) throw cli::InputError(*a.lcm, "file", "cannot open the log");
    options.can_publish = false;
    options.log_replay = true;  // a log holds whatever was recorded: read on, never wait
    result = ground::runGroundNode(replay, *a.lcm, options, done);
    cli::info("log replay: AREOMAP_PRODUCT not published (a log is read-only); " +
              std::to_string(replay.eventsTooLarge()) + " event(s) larger than the replay buffer skipped");
    return result;
  }
  platform::LcmTransport transport;
  if (!ok(transport.open(a.lcm->c_str()))) {
    throw cli::InputError(*a.lcm, "url", "LCM cannot open it (for udpm: is there a multicast route?)");
  }
  // The ground reads nothing while it makes a panorama's products (minutes): what arrives meanwhile (the next
  // site's pairs, the rover's statuses at 1 Hz) waits in LCM's queues, whole.
  transport.setQueueCapacity(0);
  cli::info(std::string("listening on ") + transport.url());
  if (!a.no_record && !options.stream_only) options.record_path = a.out + "/" + ground::kRecordingName;
  result = ground::runGroundNode(transport, *a.lcm, options, done);
  if (!result.product_published) cli::warn("AREOMAP_PRODUCT could not be published");
  if (result.record_write_errors > 0) {
    // The products are made, but a restarted node could not resume from this recording.
    run.write_errors.push_back(
        options.record_path + ": " + std::to_string(result.record_write_errors) + " of " +
        std::to_string(result.recorded + result.record_write_errors) +
        " received messages not recorded (disk full?); a restart cannot resume from it");
  }
  return result;
}

// --traverse: after the last site, the traverse steps on the sites' passes.
int finishTraverse(const GroundArgs& a, const ground::GroundNodeResult& result, StreamRun& run) {
  traverse::StreamTraverseInputs in;
  in.sites = result.sites;
  in.site_counts = result.site_counts;
  in.passes = run.passes;
  in.truth_traverse = a.truth_traverse;
  in.rover_site_poses = result.rover_site_poses;
  traverse::TraverseRunOptions o;
  o.out_dir = a.out;
  o.products = a.options.pass.products;
  o.cross_ties_csv = a.cross_ties;
  o.truth_cross_ties = a.truth_cross_ties;
  o.match_cross_ties = !a.no_cross_ties;
  o.truth_noise_px = a.noise_px;
  cli::info("traverse: " + std::to_string(run.passes.size()) + " site(s) mapped; poses, merged map, report");
  const traverse::TraverseResult r = traverse::finishStreamTraverse(in, o);
  int mapped = 0;
  for (const traverse::SiteOutcome& site : r.sites) mapped += site.ok ? 1 : 0;
  std::printf("traverse: %d of %zu sites mapped, %d site announcement(s) accepted, %zu file(s) in %s\n",
              mapped, r.sites.size(), result.site_counts.sites_announced, r.files.size(), a.out.c_str());
  if (r.rover) {
    std::printf("rover on board: %d site pose(s), %.3f m RMS from the ground's", r.rover->sites,
                r.rover->vs_ground_rms_m);
    if (r.rover->error_pct >= 0.0)
      std::printf("; position error %.2f %% of the distance driven (ground %.2f %%)", r.rover->error_pct,
                  r.rover->ground_error_pct);
    std::printf("\n");
  } else {
    std::printf("rover on board: no AREOMAP_SITE_POSE received\n");
  }
  run.write_errors.insert(run.write_errors.end(), r.write_errors.begin(), r.write_errors.end());
  return writeErrorsExit(run.write_errors);
}

// --lcm: the node over the stream, then the traverse steps or the last panorama's summary.
int runOnStream(GroundArgs& a) {
  if (platform::urlScheme(a.lcm->c_str()) == platform::UrlScheme::kInvalid) {
    throw cli::UsageError("--lcm: '" + *a.lcm + "' is not a udpm://, file:// or memq:// URL");
  }
  StreamRun run;
  const ground::GroundNodeResult result = receive(a, run);
  if (a.options.stream_only) return 0;
  if (a.options.traverse) return finishTraverse(a, result, run);
  if (a.options.panoramas != 1) return writeErrorsExit(run.write_errors);
  printSummary(result.pass.summary, result.files.size(), a.out);
  if (a.summary_json) {
    std::printf("{\"pairs\": %d, \"method1_before_px\": %.6f, \"method1_after_px\": %.6f, \"files\": %zu}\n",
                result.pass.summary.pairs, result.pass.summary.method1_before_px,
                result.pass.summary.method1_after_px, result.files.size());
  }
  return writeErrorsExit(run.write_errors);
}

}  // namespace

int main(int argc, char** argv) {
  return cli::runTool("areomap-ground", argc, argv, kUsage, [](cli::Args& args) {
    GroundArgs a = parseArgs(args);
    return a.dataset_dir ? runOnDataset(a) : runOnStream(a);
  });
}
