// One CppUTest runner per test executable. CppUTest's new/delete leak detector is switched off: lazily
// initialised caches in Eigen, OpenCV, GDAL and LCM are not leaks, and heap use is checked precisely by
// the malloc counter (platform/heap/HeapCounter.hpp) where it matters.
#include <CppUTest/CommandLineTestRunner.h>
#include <CppUTest/MemoryLeakWarningPlugin.h>

int main(int argc, char** argv) {
  MemoryLeakWarningPlugin::turnOffNewDeleteOverloads();
  MemoryLeakWarningPlugin::saveAndDisableNewDeleteOverloads();
  return CommandLineTestRunner::RunAllTests(argc, argv);
}
