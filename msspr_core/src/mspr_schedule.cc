// Ms.PR's step schedules: the sequential step, the pipelined step
// (actor-critic update on a worker thread beside the representation update)
// and its variant with the critic's gradient into the encoders.
#include <ATen/Parallel.h>

#include <algorithm>
#include <optional>

#include "async_worker.h"
#include "msspr_core/mspr_agent.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
using namespace trainer_internal;

bool MsprAgent::ReprUpdateDue(double extra_credit) const {
  return CreditDue(repr_credit_ + extra_credit);
}

bool MsprAgent::Pipelined() const {
  const std::string& p = options_.trainer.pipeline;
  if (p == "off" || !device_.is_cpu() || distributed()) return false;
  return p == "on" || at::get_num_threads() >= 2;
}

void MsprAgent::Sync() {
  if (!worker_) return;
  worker_->Wait();
  if (!pending_actor_) return;
  // A deferred actor update (pipelined, critic_grad_to_encoder): run now, on
  // the worker with its thread count, as the next step would have.
  TransitionBatch batch = std::move(*pending_actor_);
  pending_actor_.reset();
  RunOnWorker(pending_threads_,
              [this, b = std::move(batch)] { UpdateActor(b, EncodeForUpdate(b), nullptr); });
  worker_->Wait();
}

void MsprAgent::RunOnWorker(int threads, std::function<void()> task) {
  if (!worker_) worker_ = std::make_unique<AsyncWorker>();
  worker_->Run([threads, task = std::move(task)] {
    // Torch's per-thread setup first (it sets the thread's count to the
    // process-wide one), then this worker's share.
    at::internal::lazy_init_num_threads();
    const ThreadCountScope scope(threads);
    task();
  });
}

MsprAgent::~MsprAgent() {
  if (!worker_) return;
  try {
    worker_->Wait();
  } catch (const std::exception&) {
    // The error of an update nobody waits for any more: the trainer is gone.
  }
}

LossInfo MsprAgent::Step(TrainingContext& context, bool collect_info) {
  LossInfo info = NoLosses();
  LossInfo* out = collect_info ? &info : nullptr;
  // Pipelined: this thread keeps ceil(n / 2) of torch's n threads for the
  // representation update, the worker gets the rest for the actor-critic one.
  const bool pipe = Pipelined();
  const int threads = at::get_num_threads();
  const int worker_threads = std::max(1, threads / 2);
  const ThreadCountScope main_threads(pipe ? std::max(1, threads - threads / 2) : 0);
  if (pipe && options_.agent.critic_grad_to_encoder)
    return CriticGradPipelinedStep(context, collect_info, worker_threads);
  if (context.step() % options_.agent.target_update_every == 0) {
    Sync();
    UpdateTargets();
  }
  repr_credit_ += options_.representation.updates_per_step;
  while (ReprUpdateDue()) {
    // The previous step's actor-critic update reads the encoders while this
    // forward and backward run; the optimiser step waits for it.
    RepresentationBackward(context.SampleChunks(), out);
    Sync();
    StepRepresentation();
    repr_credit_ -= 1.0;
  }
  TransitionBatch batch = context.SampleTransitions();
  torch::Tensor noise = context.Noise(batch.action.size(0), batch.action.size(1));
  Sync();
  // Every update so far is done (this step's representation update, the
  // previous step's actor and critic): the average takes them in.
  UpdatePolicyAverage(context.step());
  if (options_.agent.critic_grad_to_encoder) {
    // The critic update changes the encoders: the actor re-encodes.
    UpdateCritic(batch, noise, out);
    UpdateActor(batch, out);
    return info;
  }
  // The encoders are not changed by the critic update, so the critic and the
  // actor share one encoding of the batch.
  auto actor_critic = [this](const TransitionBatch& b, const torch::Tensor& n, LossInfo* o) {
    const mspr::TransitionLatents lat = EncodeForUpdate(b);
    UpdateCritic(b, &lat, n, o);
    UpdateActor(b, lat, o);
  };
  if (pipe && !collect_info) {
    RunOnWorker(worker_threads, [actor_critic, b = std::move(batch), n = std::move(noise)] {
      actor_critic(b, n, nullptr);
    });
    return info;
  }
  actor_critic(batch, noise, out);
  return info;
}

// Pipelined with the critic's gradient into the encoders. The critic update
// writes the encoders, so it cannot overlap the representation update (as it
// does without that gradient); what can: the last step's actor update (it
// reads the encoders and the critic, writes only the actor) and this step's
// TD target (target networks only). The worker runs both beside the
// representation update; the representation optimiser waits for them. The
// random draws come in the sequential order (chunks, transitions, noise), so
// the weights are the sequential schedule's bit for bit.
LossInfo MsprAgent::CriticGradPipelinedStep(TrainingContext& context, bool collect_info,
                                            int worker_threads) {
  LossInfo info = NoLosses();
  LossInfo* out = collect_info ? &info : nullptr;
  if (context.step() % options_.agent.target_update_every == 0) {
    Sync();  // runs a deferred actor update first
    UpdateTargets();
  }
  repr_credit_ += options_.representation.updates_per_step;
  std::vector<ChunkBatch> chunks;
  for (double credit = repr_credit_; CreditDue(credit); credit -= 1.0)
    chunks.push_back(context.SampleChunks());
  TransitionBatch batch = context.SampleTransitions();
  torch::Tensor noise = context.Noise(batch.action.size(0), batch.action.size(1));
  std::optional<TransitionBatch> actor_batch = std::move(pending_actor_);
  pending_actor_.reset();
  RunOnWorker(worker_threads, [this, actor_batch = std::move(actor_batch), batch, noise] {
    if (actor_batch) UpdateActor(*actor_batch, EncodeForUpdate(*actor_batch), nullptr);
    worker_target_ = TdTarget(batch, noise, /*update=*/true);
  });
  for (const ChunkBatch& c : chunks) {
    RepresentationBackward(c, out);
    worker_->Wait();  // the actor update read the encoders
    StepRepresentation();
    repr_credit_ -= 1.0;
  }
  worker_->Wait();
  const torch::Tensor y = std::move(worker_target_);
  worker_target_ = torch::Tensor();
  UpdatePolicyAverage(context.step());
  UpdateCriticFromTarget(batch, nullptr, y, out);
  if (collect_info) {
    UpdateActor(batch, EncodeForUpdate(batch), out);
  } else {
    pending_actor_ = std::move(batch);
    pending_threads_ = worker_threads;
  }
  return info;
}

}  // namespace core
}  // namespace msspr
