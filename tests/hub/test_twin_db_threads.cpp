// The twin database under several threads at once (in the hub's test program, so that the
// tsan preset builds and runs it with the hub's tests).
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "hub_test_support.hpp"
#include "scaratwin/hub/twin_db.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const char* name) { return test::fresh_dir(std::string("robots-") + name); }

// The twin database is shared between threads: a hub records from its I/O thread while the
// command reads figures (the two-arm demo reads each robot's database while its hub still
// records), and two databases are written at once (one per robot). Under ThreadSanitizer
// (the tsan preset) a race fails this test; in every build the counts read back are exact:
// 4 writers x 3000 samples, each read back in full after the writers end.
TEST(TwinDbThreads, TwoDatabasesWrittenAndReadFromSeveralThreads) {
  const fs::path dir = fresh_dir("db-threads");
  auto a = TwinDb::open(dir / "a.db");
  auto b = TwinDb::open(dir / "b.db");
  ASSERT_TRUE(a) << a.error().message;
  ASSERT_TRUE(b) << b.error().message;
  TwinDb* dbs[2] = {a->get(), b->get()};
  int64_t runs[2] = {0, 0};
  for (int i = 0; i < 2; ++i) {
    auto r = dbs[i]->begin_run("mirror", "threads");
    ASSERT_TRUE(r) << r.error().message;
    runs[i] = *r;
  }
  constexpr int kSamples = 3000;
  std::atomic<bool> writing{true};
  std::atomic<int> failures{0};
  std::vector<std::thread> writers;
  for (int w = 0; w < 4; ++w) {
    writers.emplace_back([&, w] {
      TwinDb& db = *dbs[w % 2];
      const SampleSource src = w < 2 ? SampleSource::kPhysical : SampleSource::kVirtual;
      for (int i = 0; i < kSamples; ++i) {
        const JointRecord r{i * 0.005, i, {0.1, 0.001 * i, -0.001 * i, 0.5}, 10.0};
        if (!db.add_sample(runs[w % 2], src, r)) ++failures;
      }
    });
  }
  std::size_t reads = 0;
  std::thread reader([&] {
    while (writing) {
      for (int i = 0; i < 2; ++i) {
        auto s = dbs[i]->samples(runs[i], SampleSource::kPhysical);
        if (!s) ++failures;
        ++reads;
      }
    }
  });
  for (auto& t : writers) t.join();
  writing = false;
  reader.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_GT(reads, 0u);
  for (int i = 0; i < 2; ++i) {
    for (SampleSource src : {SampleSource::kPhysical, SampleSource::kVirtual}) {
      auto s = dbs[i]->samples(runs[i], src);
      ASSERT_TRUE(s) << s.error().message;
      EXPECT_EQ(s->size(), static_cast<std::size_t>(kSamples));
    }
  }
}

}  // namespace
}  // namespace scaratwin
