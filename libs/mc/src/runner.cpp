#include "talus/mc/runner.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#include "talus/core/threads.hpp"

namespace talus::mc {

void run_realizations(const Scene& scene, const std::vector<std::uint32_t>& indices, unsigned threads,
                      const std::function<void(RealizationResult&&)>& on_done,
                      const std::function<bool()>& stop_asked) {
  if (indices.empty()) return;
  if (threads == 0) threads = core::default_thread_count();
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, indices.size()));

  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::atomic<bool> abandon{false};  // stop_asked: the realizations in hand are dropped
  std::mutex mutex;
  std::condition_variable ready;
  std::deque<RealizationResult> finished;
  std::exception_ptr failure;
  unsigned running = threads;

  auto worker = [&] {
    while (!stop.load()) {
      const std::size_t k = next.fetch_add(1);
      if (k >= indices.size()) break;
      try {
        RealizationResult r = run_realization(scene, indices[k], &abandon);
        std::lock_guard lock(mutex);
        finished.push_back(std::move(r));
      } catch (const Abandoned&) {
        break;
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!failure) failure = std::current_exception();
        stop = true;
      }
      ready.notify_one();
    }
    std::lock_guard lock(mutex);
    --running;
    ready.notify_one();
  };

  std::vector<std::thread> pool;
  pool.reserve(threads);
  for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);

  // Results are handed over on this thread, so on_done needs no locking of its own.
  std::unique_lock lock(mutex);
  while (true) {
    const auto woken = [&] { return !finished.empty() || running == 0; };
    if (stop_asked) {
      ready.wait_for(lock, std::chrono::milliseconds(50), woken);
      if (!abandon.load() && stop_asked()) {
        abandon = true;
        stop = true;
      }
    } else {
      ready.wait(lock, woken);
    }
    if (finished.empty() && running == 0) break;
    while (!finished.empty()) {
      RealizationResult r = std::move(finished.front());
      finished.pop_front();
      if (stop.load() && failure) continue;
      lock.unlock();
      try {
        on_done(std::move(r));
      } catch (...) {
        lock.lock();
        if (!failure) failure = std::current_exception();
        stop = true;
        continue;
      }
      lock.lock();
    }
  }
  lock.unlock();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

void check_releases(const Scene& scene, const std::vector<std::uint32_t>& indices, unsigned threads) {
  if (indices.empty()) return;
  if (threads == 0) threads = core::default_thread_count();
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, indices.size()));
  const bool rough = scene.settings().stochastic.roughness;
  std::atomic<std::size_t> next{0};
  std::mutex mutex;
  // The failure of the lowest realization index, whatever the thread count.
  std::uint64_t lowest = std::numeric_limits<std::uint64_t>::max();
  std::exception_ptr failure;

  auto worker = [&] {
    // Without roughness every realization stands on the smooth base: one Surface per thread.
    std::optional<terrain::Surface> smooth;
    while (true) {
      const std::size_t k = next.fetch_add(1);
      if (k >= indices.size()) break;
      const std::uint32_t index = indices[k];
      {
        std::lock_guard lock(mutex);
        if (index > lowest) continue;
      }
      try {
        if (rough) {
          draw_release(scene, scene.base_surface().realization(index), index);
        } else {
          if (!smooth) smooth.emplace(scene.base_surface().realization(std::nullopt));
          draw_release(scene, *smooth, index);
        }
      } catch (...) {
        std::lock_guard lock(mutex);
        if (index < lowest) {
          lowest = index;
          failure = std::current_exception();
        }
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads);
  for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace talus::mc
