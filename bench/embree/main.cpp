// durer_embree_bench: one workload, the same spheres and camera rays given to Intel Embree 3 and to
// Dürer's render (or the same given rays to rtcIntersect1 and durer::cast), their images compared,
// then both timed in interleaved rounds. The report is one
// JSON object on stdout (bench/embree_compare.py reads it); progress and the agreement go to stderr.
//
//   durer_embree_bench --workload KIND [--spheres N] [--size WxH] [--runs R] [--threads T]
//
// Exit status: 0 when the images agree, 3 when they do not (then nothing is timed), 2 on bad arguments,
// 1 when Embree or Dürer fails.
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "Agreement.h"
#include "EmbreeTracer.h"
#include "Image.h"
#include "Memory.h"
#include "Workload.h"
#include "durer/render/Cast.h"
#include "durer/render/Renderer.h"

namespace bench {

namespace {

struct Options {
  std::string kind;
  size_t spheres = 1000;
  int width = 1920, height = 1080;
  int runs = 5;
  int threads = 2;
};

std::string usage() {
  std::string text =
      "usage: durer_embree_bench --workload KIND [--spheres N] [--size WxH] [--runs R] [--threads T]\nkinds:\n";
  for (const auto& [name, description] : workloadKinds()) text += "  " + name + ": " + description + "\n";
  return text;
}

long positive(const std::string& text, const std::string& field) {
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || value < 1) {
    throw std::invalid_argument(field + " must be a positive integer, got '" + text + "'");
  }
  return value;
}

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) throw std::invalid_argument(flag + " needs a value");
    const std::string value = argv[i + 1];
    if (flag == "--workload") {
      o.kind = value;
    } else if (flag == "--spheres") {
      o.spheres = static_cast<size_t>(positive(value, "--spheres"));
    } else if (flag == "--size") {
      const size_t x = value.find('x');
      if (x == std::string::npos) throw std::invalid_argument("--size must be WIDTHxHEIGHT, got '" + value + "'");
      o.width = static_cast<int>(positive(value.substr(0, x), "--size width"));
      o.height = static_cast<int>(positive(value.substr(x + 1), "--size height"));
    } else if (flag == "--runs") {
      o.runs = static_cast<int>(positive(value, "--runs"));
    } else if (flag == "--threads") {
      o.threads = static_cast<int>(positive(value, "--threads"));
    } else {
      throw std::invalid_argument("unknown option " + flag);
    }
  }
  if (o.kind.empty()) throw std::invalid_argument("--workload is required");
  return o;
}

double millisecondsOf(const std::function<void()>& work) {
  const auto start = std::chrono::steady_clock::now();
  work();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// What durer::cast writes for every given ray, in both precisions; made before the memory probes,
// as the images are, so that they count only what each tracer's scene and hierarchy take.
struct CastBuffers {
  std::vector<float> tFloat, normalsFloat;
  std::vector<double> tDouble, normalsDouble;
  std::vector<int32_t> objects, materials;

  explicit CastBuffers(size_t count)
      : tFloat(count), normalsFloat(3 * count), tDouble(count), normalsDouble(3 * count), objects(count), materials(count) {}
};

// Dürer's durer::cast of the workload's given rays (one per pixel) in `precision`: each ray's t; the
// shadow rays (Workload::occlusionRays, the last ones) cast as an occlusion query (any hit).
void castDurer(const durer::Scene& scene, const Workload& w, durer::Precision precision, int threads,
               CastBuffers& buffers, Image& image) {
  const size_t count = image.depth.size(), nearest = count - w.occlusionRays;
  const auto castInto = [&](auto& t, auto& normals) {
    using Real = typename std::decay_t<decltype(t)>::value_type;
    for (const bool anyHit : {false, true}) {
      const size_t first = anyHit ? nearest : 0, rays = anyHit ? w.occlusionRays : nearest;
      if (rays == 0) continue;
      durer::CastInput input;
      input.origins = w.rayOrigins.data() + 3 * first;
      input.directions = w.rayDirections.data() + 3 * first;
      input.count = rays;
      input.tMax = anyHit ? w.occlusionTMax : INFINITY;
      input.threads = threads;
      input.anyHit = anyHit;
      durer::CastOutput<Real> output;
      output.t = t.data() + first, output.normal = normals.data() + 3 * first;
      output.objectId = buffers.objects.data() + first, output.materialId = buffers.materials.data() + first;
      durer::JobControl control;
      durer::cast<Real>(scene, input, output, control, [] {});
    }
    std::copy(t.begin(), t.end(), image.depth.begin());
    for (size_t i = nearest; i < count; ++i) {
      if (std::isfinite(image.depth[i])) image.depth[i] = Workload::kOccluded;
    }
  };
  if (precision == durer::Precision::Float) {
    castInto(buffers.tFloat, buffers.normalsFloat);
  } else {
    castInto(buffers.tDouble, buffers.normalsDouble);
  }
  image.rays = static_cast<int64_t>(count);
}

// Dürer's render of the workload through its public API: depth only, or colour + depth with a sun;
// given rays are cast instead.
void renderDurer(const durer::Scene& scene, const Workload& w, durer::Precision precision, int threads,
                 CastBuffers& buffers, Image& image, const durer::CameraSpec& camera) {
  if (w.givenRays()) {
    castDurer(scene, w, precision, threads, buffers, image);
    return;
  }
  durer::RenderSettings settings;
  settings.width = w.width;
  settings.height = w.height;
  settings.precision = precision;
  settings.threads = threads;
  settings.passes = durer::kPassDepth | (w.sunDirection ? durer::kPassColor : 0u);
  durer::RenderTargets targets;
  targets.depth = image.depth.data();
  targets.color = w.sunDirection ? image.color.data() : nullptr;
  durer::JobControl control;
  const durer::RenderStats stats = durer::render(scene, camera, settings, targets, control, [] {});
  image.rays = stats.counters.camera + stats.counters.shadow;
}

void renderDurer(const durer::Scene& scene, const Workload& w, durer::Precision precision, int threads,
                 CastBuffers& buffers, Image& image) {
  renderDurer(scene, w, precision, threads, buffers, image, w.camera);
}

// With no ambient light and no emission, a pixel has colour exactly where its hit is lit by the sun.
void litFromColor(Image& image) {
  for (size_t i = 0; i < image.lit.size(); ++i) image.lit[i] = image.color[4 * i] > 0;
}

struct Timings {
  std::vector<double> embreeBuild, embreeTrace, embreePose, embreeFrame;
  std::vector<double> durerFirst[2], durerCached[2], durerPose[2], durerFrame[2];  // [0] float, [1] double
};

constexpr durer::Precision kPrecisions[2] = {durer::Precision::Float, durer::Precision::Double};

// The first (untimed) pass: each tracer alone in a memory probe; the images it leaves are compared.
struct FirstPass {
  MemoryProbe::Growth embree, durer[2];
  int64_t durerScene[2] = {};  // what the Scene alone holds, before a render prepares it
  Agreement agreement[2];
  Agreement poseAgreement[2];   // on the camera's other pose (not for given rays)
  Agreement frameAgreement[2];  // on an animation's next frame (not for given rays)
};

// The images of the camera's other pose (Workload::posedCamera), each tracer's scene as timeRound
// times it (built and traced from the first pose), compared.
void comparePoses(const Workload& w, const EmbreeDevice& device, int threads, CastBuffers& buffers,
                  Image (&poseImages)[3], FirstPass& pass) {
  const durer::CameraSpec posed = w.posedCamera();
  EmbreeScene embree(device, w);
  embree.commit();
  embree.trace(threads, poseImages[0]);
  embree.trace(threads, poseImages[0], posed);
  for (int p = 0; p < 2; ++p) {
    Image& image = poseImages[1 + p];
    durer::Scene scene;
    addToScene(w, scene);
    renderDurer(scene, w, kPrecisions[p], threads, buffers, image);
    renderDurer(scene, w, kPrecisions[p], threads, buffers, image, posed);
    litFromColor(image);
    pass.poseAgreement[p] = compare(poseImages[0], image);
  }
}

// The images of an animation's next frame (Workload::frameCenters(1)), each tracer as timeRound
// times it, compared.
void compareFrames(const Workload& w, const EmbreeDevice& device, int threads, CastBuffers& buffers,
                   Image (&frameImages)[3], FirstPass& pass) {
  const std::vector<double> moved = w.frameCenters(1);
  EmbreeScene animated(device, w, true);
  animated.commit();
  animated.moveSpheres(moved);
  animated.commit();
  animated.trace(threads, frameImages[0]);
  for (int p = 0; p < 2; ++p) {
    Image& image = frameImages[1 + p];
    durer::Scene scene;
    const std::vector<int32_t> ids = addToScene(w, scene);
    renderDurer(scene, w, kPrecisions[p], threads, buffers, image);
    scene.moveSpheres(ids.data(), moved.data(), nullptr, ids.size());
    renderDurer(scene, w, kPrecisions[p], threads, buffers, image);
    litFromColor(image);
    pass.frameAgreement[p] = compare(frameImages[0], image);
  }
}

FirstPass firstPass(const Workload& w, const EmbreeDevice& device, int threads, CastBuffers& buffers,
                    Image& embreeImage, Image (&durerImages)[2], Image (&frameImages)[3]) {
  FirstPass pass;
  for (int p = 0; p < 2; ++p) {
    const MemoryProbe probe;
    durer::Scene scene;
    addToScene(w, scene);
    pass.durerScene[p] = probe.growth().retained;
    renderDurer(scene, w, kPrecisions[p], threads, buffers, durerImages[p]);
    pass.durer[p] = probe.growth();
    litFromColor(durerImages[p]);
  }
  {
    const MemoryProbe probe;
    EmbreeScene scene(device, w);
    scene.commit();
    scene.trace(threads, embreeImage);
    pass.embree = probe.growth();
  }
  for (int p = 0; p < 2; ++p) pass.agreement[p] = compare(embreeImage, durerImages[p]);
  if (!w.givenRays()) {
    comparePoses(w, device, threads, buffers, frameImages, pass);
    compareFrames(w, device, threads, buffers, frameImages, pass);
  }
  return pass;
}

// One timed round: Embree (build, trace), then Dürer in each precision (first render of a fresh
// scene, which builds its hierarchy, then the same scene again, which reuses it). Unless the rays
// are given: then the camera's other pose (Workload::posedCamera: Embree's trace of its rays, Dürer's
// render, which makes the pose's view of the spheres), and an animation's next frame (every sphere
// moved, Workload::frameCenters: Embree's animated scene, built and traced untimed, updated,
// committed (a refit) and traced; Dürer's scene moved (Scene::moveSpheres) and rendered, its
// hierarchy refitted and its views made again).
void timeRound(const Workload& w, const EmbreeDevice& device, int threads, CastBuffers& buffers,
               Image& embreeImage, Image (&durerImages)[2], Image (&frameImages)[3], Timings& t) {
  const bool cameraRays = !w.givenRays();
  const std::vector<double> moved = cameraRays ? w.frameCenters(1) : std::vector<double>{};
  const durer::CameraSpec posed = cameraRays ? w.posedCamera() : w.camera;
  {
    EmbreeScene scene(device, w);
    t.embreeBuild.push_back(millisecondsOf([&] { scene.commit(); }));
    t.embreeTrace.push_back(millisecondsOf([&] { scene.trace(threads, embreeImage); }));
    if (cameraRays) t.embreePose.push_back(millisecondsOf([&] { scene.trace(threads, frameImages[0], posed); }));
  }
  if (cameraRays) {
    EmbreeScene scene(device, w, true);
    scene.commit();
    scene.trace(threads, frameImages[0]);
    t.embreeFrame.push_back(millisecondsOf([&] {
      scene.moveSpheres(moved);
      scene.commit();
      scene.trace(threads, frameImages[0]);
    }));
  }
  for (int p = 0; p < 2; ++p) {
    durer::Scene scene;
    const std::vector<int32_t> ids = addToScene(w, scene);
    const auto render = [&] { renderDurer(scene, w, kPrecisions[p], threads, buffers, durerImages[p]); };
    t.durerFirst[p].push_back(millisecondsOf(render));
    t.durerCached[p].push_back(millisecondsOf(render));
    if (!cameraRays) continue;
    t.durerPose[p].push_back(
        millisecondsOf([&] { renderDurer(scene, w, kPrecisions[p], threads, buffers, frameImages[1 + p], posed); }));
    t.durerFrame[p].push_back(millisecondsOf([&] {
      scene.moveSpheres(ids.data(), moved.data(), nullptr, ids.size());
      renderDurer(scene, w, kPrecisions[p], threads, buffers, frameImages[1 + p]);
    }));
  }
}

// --- the JSON report ---------------------------------------------------------------------------------
std::string list(const std::vector<double>& values) {
  std::ostringstream out;
  out << "[";
  for (size_t i = 0; i < values.size(); ++i) out << (i ? ", " : "") << values[i];
  return out.str() + "]";
}

std::string json(const MemoryProbe::Growth& g, const std::string& more = "") {
  return "{\"retained_bytes\": " + std::to_string(g.retained) + ", \"peak_bytes\": " + std::to_string(g.peak) + more +
         "}";
}

std::string sceneBytes(int64_t bytes) { return ", \"scene_bytes\": " + std::to_string(bytes); }

std::string json(const Agreement& a) {
  std::ostringstream out;
  out << "{\"pixels\": " << a.pixels << ", \"hit_mismatches\": " << a.hitMismatches << ", \"both_hit\": " << a.bothHit
      << ", \"depth_mismatches\": " << a.depthMismatches << ", \"depth_difference_p999\": " << a.depthDifference999
      << ", \"max_depth_difference\": " << a.maxDepthDifference << ", \"lit_mismatches\": " << a.litMismatches
      << ", \"lit_by_embree_only\": " << a.litByEmbreeOnly
      << ", \"passed\": " << (a.passed() ? "true" : "false") << "}";
  return out.str();
}

std::string report(const Options& o, const Workload& w, const FirstPass& first, const Timings& t,
                   const Image& embreeImage, const Image (&durerImages)[2]) {
  std::ostringstream out;
  out.precision(6);
  out << "{\"workload\": \"" << o.kind << "\", \"spheres\": " << w.sphereCount() << ", \"width\": " << w.width
      << ", \"height\": " << w.height << ", \"threads\": " << o.threads << ", \"runs\": " << t.embreeTrace.size()
      << ",\n \"rays\": {\"embree\": " << embreeImage.rays << ", \"durer_float\": " << durerImages[0].rays
      << ", \"durer_double\": " << durerImages[1].rays << "},\n \"embree\": {\"build_ms\": " << list(t.embreeBuild)
      << ", \"trace_ms\": " << list(t.embreeTrace) << ", \"pose_ms\": " << list(t.embreePose)
      << ", \"frame_ms\": " << list(t.embreeFrame) << "},\n";
  const char* names[2] = {"float", "double"};
  for (int p = 0; p < 2; ++p) {
    out << " \"durer_" << names[p] << "\": {\"first_ms\": " << list(t.durerFirst[p])
        << ", \"cached_ms\": " << list(t.durerCached[p]) << ", \"pose_ms\": " << list(t.durerPose[p])
        << ", \"frame_ms\": " << list(t.durerFrame[p]) << "},\n";
  }
  out << " \"agreement\": {\"float\": " << json(first.agreement[0]) << ",\n               \"double\": "
      << json(first.agreement[1]) << "},\n";
  if (!w.givenRays()) {
    out << " \"pose_agreement\": {\"float\": " << json(first.poseAgreement[0]) << ",\n                    \"double\": "
        << json(first.poseAgreement[1]) << "},\n";
    out << " \"frame_agreement\": {\"float\": " << json(first.frameAgreement[0]) << ",\n                     \"double\": "
        << json(first.frameAgreement[1]) << "},\n";
  }
  out << " \"memory\": {\"embree\": " << json(first.embree)
      << ",\n            \"durer_float\": " << json(first.durer[0], sceneBytes(first.durerScene[0]))
      << ",\n            \"durer_double\": " << json(first.durer[1], sceneBytes(first.durerScene[1]))
      << ", \"process_peak_rss_bytes\": " << processPeakRss() << "}}\n";
  return out.str();
}

void logAgreement(const Agreement (&agreement)[2], const char* what) {
  const char* names[2] = {"float", "double"};
  for (int p = 0; p < 2; ++p) {
    const Agreement& a = agreement[p];
    std::cerr << "  " << what << ", Dürer " << names[p] << " vs Embree: " << (a.passed() ? "OK" : "FAILED") << "; hit/miss "
              << a.pixels - a.hitMismatches << " of " << a.pixels << " pixels agree, depth beyond "
              << Agreement::kDepthTolerance << " relative at " << a.depthMismatches << " of " << a.bothHit
              << " (99.9th percentile " << a.depthDifference999 << ", max " << a.maxDepthDifference << "), lit "
              << a.litMismatches << " mismatches (" << a.litByEmbreeOnly << " lit by Embree only)\n";
  }
}

int run(const Options& o) {
  // A fixed mmap threshold: every large array is mapped and unmapped, never kept in the heap when
  // freed, so that each memory probe sees only its own phase's memory.
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  const Workload w = makeWorkload(o.kind, o.spheres, o.width, o.height);
  const EmbreeDevice device(o.threads);
  const bool sun = w.sunDirection.has_value();
  Image embreeImage(w.width, w.height, sun);
  Image durerImages[2] = {Image(w.width, w.height, sun), Image(w.width, w.height, sun)};
  const int frameWidth = w.givenRays() ? 0 : w.width, frameHeight = w.givenRays() ? 0 : w.height;
  Image frameImages[3] = {Image(frameWidth, frameHeight, sun), Image(frameWidth, frameHeight, sun),
                          Image(frameWidth, frameHeight, sun)};
  std::cerr << o.kind << ", " << w.sphereCount() << " spheres, " << w.width << "x" << w.height << "\n";
  CastBuffers buffers(w.givenRays() ? embreeImage.depth.size() : 0);
  const FirstPass first = firstPass(w, device, o.threads, buffers, embreeImage, durerImages, frameImages);
  logAgreement(first.agreement, "agreement");
  if (!w.givenRays()) {
    logAgreement(first.poseAgreement, "other pose's agreement");
    logAgreement(first.frameAgreement, "next frame's agreement");
  }
  const auto both = [](const Agreement (&a)[2]) { return a[0].passed() && a[1].passed(); };
  const bool agree = both(first.agreement) &&
                     (w.givenRays() || (both(first.poseAgreement) && both(first.frameAgreement)));
  Timings timings;
  for (int round = 0; agree && round < o.runs; ++round) {
    timeRound(w, device, o.threads, buffers, embreeImage, durerImages, frameImages, timings);
  }
  std::cout << report(o, w, first, timings, embreeImage, durerImages);
  return agree ? 0 : 3;
}

}  // namespace

}  // namespace bench

int main(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--help") {
    std::cout << bench::usage();
    return 0;
  }
  try {
    return bench::run(bench::parseOptions(argc, argv));
  } catch (const std::invalid_argument& e) {
    std::cerr << "durer_embree_bench: " << e.what() << "\n";
    std::cerr << bench::usage();
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "durer_embree_bench: " << e.what() << "\n";
    return 1;
  }
}
