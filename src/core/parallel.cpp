#include "src/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace amhv {

namespace {

// One loop's items, handed out one at a time to the caller and its helpers.
class Loop {
public:
    Loop(std::size_t count, const std::function<void(std::size_t)>& work) : count_(count), work_(work) {}

    void run() {
        for (std::size_t i = next_++; i < count_ && !failed_; i = next_++) {
            try {
                work_(i);
            } catch (...) {
                // Items are handed out in order, so every item below this one has started: keeping
                // the lowest failing item's exception reports the same failure on every run.
                const std::lock_guard lock(failure_lock_);
                if (!failure_ || i < failed_item_) failure_ = std::current_exception(), failed_item_ = i;
                failed_ = true;
            }
        }
    }
    void rethrow() const {
        if (failure_) std::rethrow_exception(failure_);
    }

private:
    const std::size_t count_;
    const std::function<void(std::size_t)>& work_;
    std::atomic<std::size_t> next_{0};
    std::atomic<bool> failed_{false};
    std::exception_ptr failure_;
    std::size_t failed_item_ = 0;
    std::mutex failure_lock_;
};

// Helper threads started once and asleep on a condition variable between loops: starting and
// joining threads for every loop cost about 45 us on the 2-core VM, and the voxeliser runs a dozen
// loops a call. Asleep they take no core from lavapipe's own threads (idle OpenMP workers spin,
// and slowed the sweep's dispatches by up to half). One loop at a time: a loop started while the
// helpers are busy (from inside a loop, or from another thread) starts threads of its own.
class Helpers {
public:
    static Helpers& instance() {
        static Helpers helpers(core_count() - 1);
        return helpers;
    }

    std::size_t size() const { return threads_.size(); }

    // Runs `loop` on the caller and up to `wanted` helpers; false (nothing run) while another loop
    // has them.
    bool run(Loop& loop, std::size_t wanted) {
        if (busy_.exchange(true)) return false;
        {
            const std::lock_guard lock(mutex_);
            loop_ = &loop;
            wanted_ = std::min(wanted, threads_.size());
            joined_ = 0;
            ++generation_;
        }
        wake_.notify_all();
        loop.run();
        {
            // No helper joins once the caller is done; those that joined finish their last item.
            std::unique_lock lock(mutex_);
            wanted_ = 0;
            done_.wait(lock, [&] { return running_ == 0; });
            loop_ = nullptr;
        }
        busy_ = false;
        return true;
    }

    ~Helpers() {
        {
            const std::lock_guard lock(mutex_);
            stopping_ = true;
        }
        wake_.notify_all();
        threads_.clear();  // joins
    }

private:
    explicit Helpers(unsigned count) {
        for (unsigned t = 0; t < count; ++t) threads_.emplace_back([this] { serve(); });
    }

    void serve() {
        std::uint64_t seen = 0;
        std::unique_lock lock(mutex_);
        for (;;) {
            wake_.wait(lock, [&] { return stopping_ || (generation_ != seen && joined_ < wanted_); });
            if (stopping_) return;
            seen = generation_;
            ++joined_;
            ++running_;
            Loop* loop = loop_;
            lock.unlock();
            loop->run();
            lock.lock();
            if (--running_ == 0) done_.notify_one();
        }
    }

    std::mutex mutex_;
    std::condition_variable wake_, done_;
    std::atomic<bool> busy_{false};
    Loop* loop_ = nullptr;
    std::size_t wanted_ = 0, joined_ = 0, running_ = 0;
    std::uint64_t generation_ = 0;
    bool stopping_ = false;
    std::vector<std::jthread> threads_;
};

}  // namespace

unsigned core_count() { return std::max(1u, std::thread::hardware_concurrency()); }

void parallel_for(std::size_t count, const std::function<void(std::size_t)>& work, unsigned threads) {
    if (count == 0) return;
    if (threads == 0) threads = core_count();
    const std::size_t helpers = std::min<std::size_t>(threads, count) - 1;
    Loop loop(count, work);
    if (helpers == 0) {
        loop.run();
    } else if (Helpers& pool = Helpers::instance(); helpers <= pool.size() && pool.run(loop, helpers)) {
        // run by the helpers
    } else {
        // More threads than the helpers, or they are busy: threads of this loop's own.
        std::vector<std::jthread> pool_of_loop;
        pool_of_loop.reserve(helpers);
        for (std::size_t t = 0; t < helpers; ++t) pool_of_loop.emplace_back([&] { loop.run(); });
        loop.run();
    }  // joined here
    loop.rethrow();
}

void copy_on_threads(void* to, const void* from, std::size_t bytes) {
    constexpr std::size_t kPiece = std::size_t(4) << 20;
    auto* out = static_cast<unsigned char*>(to);
    const auto* in = static_cast<const unsigned char*>(from);
    parallel_for((bytes + kPiece - 1) / kPiece, [&](std::size_t piece) {
        const std::size_t at = piece * kPiece;
        std::memcpy(out + at, in + at, std::min(kPiece, bytes - at));
    });
}

}  // namespace amhv
