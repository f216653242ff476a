#include "skinspec/api/server.hpp"

#include <algorithm>
#include <thread>
#include <vector>

#include <boost/asio/ip/tcp.hpp>

#include "descriptors.hpp"
#include "server_state.hpp"
#include "session.hpp"

namespace skinspec::api {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using detail::ConnectionTable;

namespace {

// Descriptors set aside beyond those open when listening: the database's readers and their
// journals, logs, the instrument's port, the spare descriptor, short-lived files.
constexpr std::size_t kReservedDescriptors = 64;

ApiError refusal(ConnectionTable::Refusal why, const std::string& client) {
  return {ErrorKind::unavailable, "too_many_connections",
          why == ConnectionTable::Refusal::client_full ? "too many connections from " + client + ", none of them idle"
                                                       : "too many connections, none of them idle"};
}

// A new connection: admitted into the table (maybe in the place of an idle one, closed now)
// and served, or refused with a 503.
void admit(const std::shared_ptr<Server::State>& state, tcp::socket socket, std::size_t io_thread) {
  boost::system::error_code ec;
  const auto remote = socket.remote_endpoint(ec);
  const std::string client = ec ? std::string() : remote.address().to_string();
  Metrics& metrics = state->router.metrics();
  std::shared_ptr<detail::Session> session, evicted;
  ConnectionTable::Admission admission;
  {
    std::lock_guard lock(state->mutex);
    if (state->stopping) return;  // the socket closes as it goes
    const ConnectionTable::Id id = ++state->last_id;
    admission = state->connections->admit(id, client);
    if (admission.refusal == ConnectionTable::Refusal::none) {
      session = detail::make_session(std::move(socket), state, id);
      state->sessions.emplace(id, session);
    }
    if (admission.evicted) {
      if (const auto it = state->sessions.find(*admission.evicted); it != state->sessions.end()) {
        evicted = it->second.lock();
        state->sessions.erase(it);
      }
    }
    metrics.set_open_connections(static_cast<std::int64_t>(state->connections->size()));
  }
  if (admission.evicted) metrics.record_evicted_connection();
  if (evicted) evicted->evict();
  if (!session) {
    metrics.record_rejected_connection();
    return detail::refuse_connection(socket, detail::refusal_bytes(refusal(admission.refusal, client)));
  }
  metrics.record_accepted_connection(io_thread);
  session->run();
}

}  // namespace

Server::State::State(const Router& r, ServerOptions o)
    : router(r),
      options(std::move(o)),
      limits{options.body_limit, options.header_limit},
      workers(static_cast<std::size_t>(std::max(1, options.worker_threads))),
      compute(options.compute_threads, options.compute_queue,
              [&metrics = r.metrics()](std::size_t running, std::size_t waiting) {
                metrics.set_compute_load(running, waiting);
              }) {}

Server::Server(const Router& router, ServerOptions options)
    : state_(std::make_shared<State>(router, std::move(options))) {
  for (int i = 1; i < state_->options.io_threads; ++i) {
    more_contexts_.push_back(std::make_unique<asio::io_context>(1));
    keep_running_.push_back(asio::make_work_guard(*more_contexts_.back()));
  }
}

Server::~Server() {
  stop();
  // The listener's accept, cancelled by stop(), holds a socket made for another thread's
  // context, which goes first: it is let go of now.
  ioc_.restart();
  ioc_.poll();
  ioc_.stop();
  for (auto& context : more_contexts_) context->stop();
  state_->workers.join();
  state_->compute.join();
  state_->pullers.hang_up_and_join();
}

std::expected<void, std::string> Server::listen() {
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(state_->options.address, ec);
  if (ec) return std::unexpected("bad listen address '" + state_->options.address + "': " + ec.message());
  const std::size_t cap = detail::connection_cap(state_->options.max_connections, detail::descriptor_limit(),
                                                 detail::open_descriptors(), kReservedDescriptors);
  {
    std::lock_guard lock(state_->mutex);
    state_->connections.emplace(ConnectionTable::Limits{cap, state_->options.max_connections_per_client});
  }
  const std::weak_ptr<State> weak = state_;
  std::vector<asio::io_context*> contexts{&ioc_};
  for (auto& context : more_contexts_) contexts.push_back(context.get());
  state_->router.metrics().set_io_threads(contexts.size());
  state_->listener = std::make_shared<detail::Listener>(
      std::move(contexts),
      [weak](tcp::socket socket, std::size_t io_thread) {
        if (const auto state = weak.lock()) admit(state, std::move(socket), io_thread);
      },
      [&metrics = state_->router.metrics()] { metrics.record_rejected_connection(); });
  if (auto opened = state_->listener->open(tcp::endpoint{address, state_->options.port}); !opened) return opened;
  state_->listener->start();
  return {};
}

unsigned short Server::port() const { return state_->listener ? state_->listener->port() : 0; }

ServerLimits Server::limits() const {
  std::lock_guard lock(state_->mutex);
  if (!state_->connections) return {};
  return {state_->connections->limits().total, state_->connections->limits().per_client, detail::descriptor_limit()};
}

void Server::run() {
  std::vector<std::thread> threads;
  for (auto& context : more_contexts_) threads.emplace_back([&context] { context->run(); });
  ioc_.run();
  for (auto& t : threads) t.join();
  state_->workers.join();
  state_->compute.join();
  state_->pullers.join_all();
}

void Server::stop() {
  std::vector<std::shared_ptr<detail::Session>> sessions;
  {
    std::lock_guard lock(state_->mutex);
    if (state_->stopping) return;
    state_->stopping = true;
    for (const auto& [id, weak] : state_->sessions)
      if (auto s = weak.lock()) sessions.push_back(std::move(s));
  }
  if (state_->listener) state_->listener->close();
  for (auto& s : sessions) s->shut_down();
  state_->pullers.close_all();
  // The other threads' contexts run on while connections on them are open, and no longer.
  for (auto& guard : keep_running_) guard.reset();
}

}  // namespace skinspec::api
