/// @file runner_queue.cpp
/// @brief RunnerQueue: requests to the physics thread and its wake-ups.
#include "constrained_particles/ros/runner_queue.hpp"

#include <utility>

namespace constrained_particles
{
namespace
{
constexpr auto REPLY_POLL = std::chrono::milliseconds(50);
}  // namespace

RunnerReply refusedReply(const std::string& message, const std::string& field)
{
  RunnerReply reply;
  reply.success = false;
  reply.message = message;
  reply.field = field;
  return reply;
}

RunnerReply acceptedReply(const std::string& message)
{
  RunnerReply reply;
  reply.success = true;
  reply.message = message;
  return reply;
}

RunnerReply RunnerQueue::submit(std::function<RunnerReply()> apply)
{
  auto request = std::make_shared<Request>();
  request->apply = std::move(apply);
  std::future<RunnerReply> future = request->reply.get_future();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_)
      return refusedReply("the node is shutting down");
    request->queued_at_batch = batches_;
    queue_.push_back(request);
  }
  wake_.notify_all();
  return await(future);
}

RunnerReply RunnerQueue::await(std::future<RunnerReply>& future) const
{
  while (future.wait_for(REPLY_POLL) != std::future_status::ready)
    if (stopping_ && future.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
      return refusedReply("the node is shutting down");
  return future.get();
}

std::deque<std::shared_ptr<RunnerQueue::Request>> RunnerQueue::take(std::uint64_t& batches)
{
  std::deque<std::shared_ptr<Request>> requests;
  std::lock_guard<std::mutex> lock(mutex_);
  requests.swap(queue_);
  batches = batches_;
  return requests;
}

void RunnerQueue::countBatch()
{
  std::lock_guard<std::mutex> lock(mutex_);
  ++batches_;
}

void RunnerQueue::wake()
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
  }
  wake_.notify_all();
}

void RunnerQueue::wait(Clock::time_point until, const std::function<bool()>& ready)
{
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait_until(lock, until, [this, &ready] { return stopping_ || !queue_.empty() || ready(); });
}

void RunnerQueue::stop()
{
  {
    std::lock_guard<std::mutex> lock(mutex_);  // not between the owner's check and its wait
    stopping_ = true;
  }
  wake_.notify_all();
}

}  // namespace constrained_particles
