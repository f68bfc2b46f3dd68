#include "server/http_server.hpp"

#include "server/byte_range.hpp"
#include "server/json_text.hpp"
#include "server/problem.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <iterator>
#include <netdb.h>
#include <optional>
#include <poll.h>
#include <random>
#include <strings.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>
#include <unordered_map>

namespace hocurve::server {
namespace {

using Clock = std::chrono::steady_clock;

thread_local int t_socket = -1;
thread_local bool t_close_after = false;
thread_local bool t_read_timed_out = false;
thread_local std::string t_hidden_range;  // the Range value kept from the library, this request

/// poll() on one socket, retried on EINTR; the revents, 0 on timeout.
short poll_one(int fd, short events, int timeout_ms) {
  pollfd p = {fd, events, 0};
  int n;
  do {
    n = ::poll(&p, 1, timeout_ms);
  } while (n < 0 && errno == EINTR);
  return n > 0 ? p.revents : 0;
}

int timeout_ms(time_t sec, time_t usec) { return (int)std::min<long long>((long long)sec * 1000 + usec / 1000, 1 << 30); }

ssize_t recv_some(int fd, char* ptr, size_t size, int flags) {
  ssize_t n;
  do {
    n = ::recv(fd, ptr, size, flags);
  } while (n < 0 && errno == EINTR);
  return n;
}

bool is_tchar(unsigned char c) {
  return std::isalnum(c) || (c && std::strchr("!#$%&'*+-.^_`|~", c));
}

std::string lower_trimmed(const char* b, const char* e) {
  while (b < e && (*b == ' ' || *b == '\t')) ++b;
  while (e > b && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) --e;
  std::string s(b, e);
  for (char& ch : s) ch = (char)std::tolower((unsigned char)ch);
  return s;
}

/// If a header line (without its '\n') names Range with a value cpp-httplib refuses, keeps the
/// value in t_hidden_range and returns true. Name and value are cut as the library cuts them: the
/// name up to ':', blanks around the value.
bool hide_refused_range(const char* line, size_t size) {
  static const char name[] = "range:";
  if (size < sizeof name - 1 || strncasecmp(line, name, sizeof name - 1) != 0) return false;
  size_t b = sizeof name - 1, e = size;
  while (b < e && (line[b] == ' ' || line[b] == '\t')) ++b;
  while (e > b && (line[e - 1] == ' ' || line[e - 1] == '\t' || line[e - 1] == '\r')) --e;
  std::string value(line + b, e - b);
  if (!httplib_refuses_range(value)) return false;
  if (t_hidden_range.empty()) t_hidden_range = std::move(value);
  return true;
}

/// Drops from the head `buf[0, head_end)` the Range lines the library would refuse; returns the
/// head's new length.
size_t hide_refused_ranges(std::string& buf, size_t head_end) {
  size_t at = 0;
  while (at < head_end) {
    const size_t nl = buf.find('\n', at);
    if (nl == std::string::npos || nl >= head_end) break;
    if (at > 0 && hide_refused_range(buf.data() + at, nl - at)) {
      buf.erase(at, nl + 1 - at);
      head_end -= nl + 1 - at;
    } else {
      at = nl + 1;
    }
  }
  return head_end;
}

/// The socket of one connection for one request: its head and whatever followed it come from the
/// front end's buffer; bytes read past the end of the request stay for the next one.
class ConnectionStream : public httplib::Stream {
 public:
  ConnectionStream(int sock, int read_ms, int write_ms, std::string buf, size_t head_end, bool chunked)
      : sock_(sock), read_ms_(read_ms), write_ms_(write_ms), buf_(std::move(buf)), head_end_(head_end), chunked_(chunked) {}

  /// The bytes received and not handed out: the start of the next request.
  std::string rest() { return buf_.substr(pos_); }
  /// The body broke the chunked grammar: where the next request starts is unknown.
  bool framing_broken() const { return broken_; }
  /// The library read the whole body of `length` bytes (or all chunks): it skips the body of
  /// requests it has no use for (GET, a chunked DELETE), which would then be read as the next
  /// request, one a proxy never saw (request smuggling).
  bool body_read(unsigned long long length) const {
    return chunked_ ? framing_.done() : handed_ >= head_end_ + length;
  }

  bool is_readable() const override { return pos_ < buf_.size() || socket_readable(); }

  /// Writable unless reset: a client that only shut down its sending side still reads the answer.
  bool is_writable() const override {
    const short r = poll_one(sock_, POLLOUT, write_ms_);
    return (r & POLLOUT) && !(r & (POLLERR | POLLHUP));
  }

  ssize_t read(char* ptr, size_t size) override {
    if (broken_) return -1;
    ssize_t n;
    if (pos_ < buf_.size()) {
      n = (ssize_t)std::min(size, buf_.size() - pos_);
      std::memcpy(ptr, buf_.data() + pos_, (size_t)n);
      pos_ += (size_t)n;
    } else {
      if (!socket_readable()) {
        t_read_timed_out = true;
        return -1;
      }
      if (size >= kChunk) {
        n = recv_some(sock_, ptr, size, 0);
      } else {
        buf_.resize(kChunk);
        n = recv_some(sock_, buf_.data(), kChunk, 0);
        buf_.resize(n > 0 ? (size_t)n : 0);
        pos_ = 0;
        if (n <= 0) return n;
        n = (ssize_t)std::min(size, buf_.size());
        std::memcpy(ptr, buf_.data(), (size_t)n);
        pos_ = (size_t)n;
      }
      if (n <= 0) return n;
    }
    // Body bytes (past the head) of a chunked request go through the grammar check.
    const size_t before = handed_;
    handed_ += (size_t)n;
    if (chunked_ && !framing_.done() && handed_ > head_end_) {
      const size_t skip = before < head_end_ ? head_end_ - before : 0;
      if (!framing_.feed(ptr + skip, (size_t)n - skip)) {
        broken_ = true;
        return -1;
      }
    }
    return n;
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n;
    do {
      n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(true, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(false, ip, port); }
  socket_t socket() const override { return sock_; }

 private:
  static constexpr size_t kChunk = 16 * 1024;

  bool socket_readable() const { return poll_one(sock_, POLLIN, read_ms_) & (POLLIN | POLLHUP | POLLERR); }

  void address(bool peer, std::string& ip, int& port) const {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if ((peer ? ::getpeername(sock_, (sockaddr*)&addr, &len) : ::getsockname(sock_, (sockaddr*)&addr, &len)) != 0) return;
    char host[NI_MAXHOST], serv[NI_MAXSERV];
    if (::getnameinfo((sockaddr*)&addr, len, host, sizeof host, serv, sizeof serv, NI_NUMERICHOST | NI_NUMERICSERV) != 0)
      return;
    ip = host;
    port = std::atoi(serv);
  }

  int sock_, read_ms_, write_ms_;
  std::string buf_;
  size_t pos_ = 0;
  size_t head_end_;      // the head's length: what comes after it is the body
  size_t handed_ = 0;    // bytes handed to the library so far
  bool chunked_;
  ChunkedFraming framing_;
  bool broken_ = false;
};

/// A problem answer written by the front end, for requests that never reach the library.
std::string canned_answer(int status, const char* reason, const std::string& type, const std::string& detail) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  char rid[24];
  std::snprintf(rid, sizeof rid, "%016llx", (unsigned long long)rng());
  nlohmann::json p = make_problem(status, type, detail);
  p["request_id"] = rid;
  const std::string body = json_text(p) + "\n";
  std::string out = "HTTP/1.1 " + std::to_string(status) + " " + reason + "\r\n";
  out += "Content-Type: application/problem+json\r\nContent-Length: " + std::to_string(body.size()) + "\r\n";
  out += std::string("Connection: close\r\nX-Request-Id: ") + rid + "\r\n";
  if (status == 503) out += "Retry-After: 2\r\n";
  return out + "\r\n" + body;
}

}  // namespace

/// A client connection while the front end owns it: waiting for (the rest of) a request head, or
/// lingering after a refusal or a last answer.
struct HttpServer::Connection {
  int fd = -1;
  std::string buf;            // received, not yet handed to the library
  Clock::time_point deadline;
  bool started = false;       // a byte of the current request has arrived
  bool closing = false;       // answered for the last time: input is read and dropped until EOF
  size_t served = 0;          // requests answered on this connection
  // The head being read: where the first line not yet complete starts, and what it said so far.
  size_t scanned = 0, head_end = 0, fields = 0, lengths = 0;
  unsigned long long length = 0;  // Content-Length
  bool http10 = false, has_te = false, bad_length = false;
  std::string te;
  void next_request() {
    scanned = head_end = fields = lengths = 0;
    length = 0;
    http10 = has_te = bad_length = false;
    te.clear();
    started = !buf.empty();
  }
};

/// The front end's thread: accepts, reads heads, hands complete ones to the pool.
class Front {
 public:
  using Conn = HttpServer::Connection;
  Front(HttpServer& s, int listener) : s_(s), listener_(listener) {}

  bool run() {
    ep_ = ::epoll_create1(EPOLL_CLOEXEC);
    if (ep_ < 0) return false;
    watch(listener_, EPOLLIN, EPOLL_CTL_ADD);
    watch(s_.wake_fd_, EPOLLIN, EPOLL_CTL_ADD);
    epoll_event events[256];
    auto last_sweep = Clock::now();
    while (!s_.halted_) {
      const int n = ::epoll_wait(ep_, events, 256, 100);
      for (int i = 0; i < n; ++i) {
        const int fd = events[i].data.fd;
        if (fd == listener_) accept_all();
        else if (fd == s_.wake_fd_) adopt_returned();
        else if (auto it = conns_.find(fd); it != conns_.end()) on_readable(it->second);
      }
      const auto now = Clock::now();
      if (now - last_sweep >= std::chrono::milliseconds(100)) {
        sweep(now);
        last_sweep = now;
      }
    }
    for (auto& [fd, c] : conns_) drop(c, false);
    conns_.clear();
    ::close(ep_);
    return true;
  }

 private:
  void watch(int fd, uint32_t events, int op) {
    epoll_event ev{};
    ev.events = events;
    ev.data.fd = fd;
    ::epoll_ctl(ep_, op, fd, &ev);
  }

  void accept_all() {
    for (;;) {
      const int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) {
          // Out of descriptors or memory: stop watching the listener a moment rather than spin.
          watch(listener_, 0, EPOLL_CTL_MOD);
          accept_paused_ = Clock::now() + std::chrono::milliseconds(50);
        }
        return;
      }
      if (conns_.size() >= s_.limits_.connections) {
        const std::string a = canned_answer(503, "Service Unavailable", "server-busy", "too many open connections; retry later");
        (void)::send(fd, a.data(), a.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
        ::close(fd);
        continue;
      }
      // As the library sets them: blocking reads and writes on the pool threads time out too.
      timeval rt{(time_t)s_.read_timeout_sec_, (suseconds_t)s_.read_timeout_usec_};
      timeval wt{(time_t)s_.write_timeout_sec_, (suseconds_t)s_.write_timeout_usec_};
      ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &rt, sizeof rt);
      ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &wt, sizeof wt);
      auto* c = new Conn;
      c->fd = fd;
      c->deadline = Clock::now() + head_time();
      conns_[fd] = c;
      watch(fd, EPOLLIN, EPOLL_CTL_ADD);
    }
  }

  Clock::duration head_time() const {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s_.limits_.head_seconds));
  }

  void adopt_returned() {
    uint64_t v;
    (void)!::read(s_.wake_fd_, &v, sizeof v);
    std::vector<Conn*> back;
    {
      std::lock_guard<std::mutex> lock(s_.returned_mutex_);
      back.swap(s_.returned_);
    }
    for (Conn* c : back) {
      conns_[c->fd] = c;
      watch(c->fd, EPOLLIN, EPOLL_CTL_ADD);
      if (c->closing) {
        linger(c);
        continue;
      }
      c->deadline = Clock::now() + (c->started ? head_time() : std::chrono::seconds(s_.keep_alive_timeout_sec_));
      buffered_ += c->buf.size();
      examine(c);  // a pipelined request may be whole already
    }
  }

  void on_readable(Conn* c) {
    char tmp[16 * 1024];
    if (c->closing) {
      const ssize_t n = recv_some(c->fd, tmp, sizeof tmp, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) drop(c);
      return;
    }
    const size_t room = std::min(sizeof tmp, s_.limits_.head_bytes + 1 - std::min(c->buf.size(), s_.limits_.head_bytes));
    const ssize_t n = recv_some(c->fd, tmp, room, MSG_DONTWAIT);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (n <= 0) return drop(c);  // gone, mid-head or between requests: nobody to answer
    if (!c->started) {
      c->started = true;
      c->deadline = Clock::now() + head_time();
    }
    c->buf.append(tmp, (size_t)n);
    buffered_ += (size_t)n;
    if (buffered_ > s_.limits_.buffered_bytes)
      return refuse(c, 503, "Service Unavailable", "server-busy", "too many request heads being received; retry later");
    examine(c);
  }

  /// Reads the lines of c's head received so far: refuses, waits for more, or dispatches.
  void examine(Conn* c) {
    const FrontLimits& L = s_.limits_;
    if (c->scanned == 0) {  // RFC 9112 2.2: empty lines before a request line are ignored
      const size_t skip = std::min(c->buf.find_first_not_of("\r\n"), c->buf.size());
      c->buf.erase(0, skip);
      buffered_ -= skip;
    }
    const std::string& b = c->buf;
    for (;;) {
      const size_t nl = b.find('\n', c->scanned);
      const bool request_line = c->scanned == 0;
      const size_t line = (nl == std::string::npos ? b.size() : nl) - c->scanned;
      if (line > L.line_bytes)
        return request_line ? refuse(c, 414, "URI Too Long", "uri-too-long", "request line longer than " + kib(L.line_bytes))
                            : refuse(c, 431, "Request Header Fields Too Large", "header-too-large",
                                     "a header field longer than " + kib(L.line_bytes));
      if (nl == std::string::npos) break;
      const char* s = b.data() + c->scanned;
      const size_t len = line > 0 && s[line - 1] == '\r' ? line - 1 : line;
      c->scanned = nl + 1;
      if (request_line) {
        c->http10 = len >= 8 && std::memcmp(s + len - 8, "HTTP/1.0", 8) == 0;
        continue;
      }
      if (len == 0) {
        c->head_end = c->scanned;
        return dispatch(c);
      }
      if (++c->fields > L.head_fields)
        return refuse(c, 431, "Request Header Fields Too Large", "header-too-large",
                      "more than " + std::to_string(L.head_fields) + " header fields");
      // RFC 9112 5.1/5.2: no blank before the colon, no line folding; names are tokens.
      const char* colon = (const char*)std::memchr(s, ':', len);
      if (!colon || colon == s || !std::all_of(s, colon, [](char ch) { return is_tchar((unsigned char)ch); }))
        return refuse(c, 400, "Bad Request", "invalid-request", "malformed header field (RFC 9112 section 5)");
      const size_t name = (size_t)(colon - s);
      if (name == 14 && strncasecmp(s, "content-length", 14) == 0) {
        ++c->lengths;
        const std::string v = lower_trimmed(colon + 1, s + len);
        c->bad_length |= v.empty() || v.size() > 18 || v.find_first_not_of("0123456789") != std::string::npos;
        if (!c->bad_length) c->length = std::stoull(v);
      } else if (name == 17 && strncasecmp(s, "transfer-encoding", 17) == 0) {
        c->te += (c->has_te ? ", " : "") + lower_trimmed(colon + 1, s + len);
        c->has_te = true;
      }
    }
    if (b.size() > L.head_bytes)
      refuse(c, 431, "Request Header Fields Too Large", "header-too-large", "request head larger than " + kib(L.head_bytes));
  }

  static std::string kib(size_t bytes) { return std::to_string(bytes / 1024) + " KiB"; }

  /// A complete head: its framing is checked (RFC 9112 6.1 and 6.3), then a pool thread takes it.
  void dispatch(Conn* c) {
    if (c->lengths > 1)
      return refuse(c, 400, "Bad Request", "invalid-request", "more than one Content-Length header");
    if (c->bad_length) return refuse(c, 400, "Bad Request", "invalid-request", "Content-Length is not a number");
    if (c->has_te) {
      // Which of the two framings an intermediary used is unknowable (request smuggling).
      if (c->lengths) return refuse(c, 400, "Bad Request", "invalid-request", "both Transfer-Encoding and Content-Length");
      if (c->http10) return refuse(c, 400, "Bad Request", "invalid-request", "Transfer-Encoding in an HTTP/1.0 request");
      if (c->te != "chunked")
        return refuse(c, 501, "Not Implemented", "not-implemented",
                      "Transfer-Encoding '" + c->te.substr(0, 64) + "' is not supported (only chunked)");
    }
    ::epoll_ctl(ep_, EPOLL_CTL_DEL, c->fd, nullptr);
    conns_.erase(c->fd);
    buffered_ -= c->buf.size();
    (is_probe(c) ? s_.probe_queue_ : s_.task_queue_)->enqueue([&s = s_, c] { s.serve_connection(c); });
  }

  static bool is_probe(const Conn* c) {
    if (c->length > 0 || c->has_te) return false;
    for (const char* p : {"GET /healthz ", "GET /readyz ", "GET /metrics ", "HEAD /healthz ", "HEAD /readyz "})
      if (c->buf.compare(0, std::strlen(p), p) == 0) return true;
    return false;
  }

  /// Answers a request the library never sees, then lingers: the client reads the answer before
  /// the close (closing with its request unread would reset the connection first).
  void refuse(Conn* c, int status, const char* reason, const std::string& type, const std::string& detail) {
    const std::string a = canned_answer(status, reason, type, detail);
    (void)::send(c->fd, a.data(), a.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (s_.on_refusal_) s_.on_refusal_(c->buf.substr(0, std::min<size_t>(c->buf.find(' '), 16)), status);
    buffered_ -= c->buf.size();
    std::string().swap(c->buf);
    linger(c);
  }

  void linger(Conn* c) {
    c->closing = true;
    ::shutdown(c->fd, SHUT_WR);
    c->deadline = Clock::now() + std::chrono::seconds(2);
  }

  void sweep(Clock::time_point now) {
    if (accept_paused_ && now >= *accept_paused_) {
      watch(listener_, EPOLLIN, EPOLL_CTL_MOD);
      accept_paused_.reset();
    }
    std::vector<Conn*> late;
    for (auto& [fd, c] : conns_)
      if (now >= c->deadline) late.push_back(c);
    for (Conn* c : late) {
      if (c->closing || !c->started) drop(c);  // an idle connection simply ends
      else refuse(c, 408, "Request Timeout", "request-timeout", "the request head did not arrive in time");
    }
  }

  void drop(Conn* c, bool erase = true) {
    if (!c->closing) buffered_ -= c->buf.size();
    ::close(c->fd);  // also leaves the epoll set
    if (erase) conns_.erase(c->fd);
    delete c;
  }

  HttpServer& s_;
  int listener_;
  int ep_ = -1;
  std::unordered_map<int, Conn*> conns_;
  size_t buffered_ = 0;
  std::optional<Clock::time_point> accept_paused_;
};

HttpServer::HttpServer() { wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK); }

HttpServer::~HttpServer() {
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

bool HttpServer::serve() {
  const int listener = svr_sock_;
  if (listener == INVALID_SOCKET || wake_fd_ < 0) return false;
  // The library listened with a backlog of 5: bursts of connects were reset or waited for SYN
  // retries (1 s, 3 s). listen() again only enlarges the queue.
  ::listen(listener, SOMAXCONN);
  ::fcntl(listener, F_SETFL, ::fcntl(listener, F_GETFL) | O_NONBLOCK);
  task_queue_.reset(new_task_queue ? new_task_queue() : new httplib::ThreadPool(8));
  probe_queue_.reset(new httplib::ThreadPool(2));
  Front front(*this, listener);
  const bool ok = front.run();
  task_queue_->shutdown();  // waits for the requests being served
  probe_queue_->shutdown();
  std::vector<Connection*> back;
  {
    std::lock_guard<std::mutex> lock(returned_mutex_);
    back.swap(returned_);
  }
  for (Connection* c : back) {
    ::close(c->fd);
    delete c;
  }
  ::close(listener);
  svr_sock_ = INVALID_SOCKET;
  return ok;
}

void HttpServer::halt() {
  halted_ = true;
  const uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
}

void HttpServer::give_back(Connection* c) {
  if (halted_) {
    ::close(c->fd);
    delete c;
    return;
  }
  {
    std::lock_guard<std::mutex> lock(returned_mutex_);
    returned_.push_back(c);
  }
  const uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
}

void HttpServer::serve_connection(Connection* c) {
  t_socket = c->fd;
  t_close_after = false;
  t_read_timed_out = false;
  t_hidden_range.clear();
  const size_t head_end = hide_refused_ranges(c->buf, c->head_end);
  ConnectionStream strm(c->fd, timeout_ms(read_timeout_sec_, read_timeout_usec_),
                        timeout_ms(write_timeout_sec_, write_timeout_usec_), std::move(c->buf), head_end, c->has_te);
  // At most keep_alive_max_count_ requests a connection (the last answer says Connection: close).
  const bool last = c->served + 1 >= keep_alive_max_count_;
  bool closed = false;
  const bool ok = process_request(strm, last, closed, nullptr);
  c->closing = !ok || closed || last || t_close_after || !strm.body_read(c->length) || halted_;
  c->buf = c->closing ? std::string() : strm.rest();
  ++c->served;
  c->next_request();
  t_socket = -1;
  t_close_after = false;
  t_hidden_range.clear();
  give_back(c);
}

int current_connection_socket() { return t_socket; }

void close_connection_after_response() { t_close_after = true; }

bool request_read_timed_out() { return t_read_timed_out; }

std::string range_header(const httplib::Request& req) {
  return req.has_header("Range") ? req.get_header_value("Range") : t_hidden_range;
}

bool ChunkedFraming::feed(const char* data, std::size_t n) {
  auto hex = [](char ch) -> int {
    if (ch >= '0' && ch <= '9') return ch - '0';
    ch = (char)std::tolower((unsigned char)ch);
    return ch >= 'a' && ch <= 'f' ? ch - 'a' + 10 : -1;
  };
  auto ctl = [](unsigned char ch) { return (ch < 0x20 && ch != '\t') || ch == 0x7f; };
  for (std::size_t i = 0; i < n && state_ != kBad && state_ != kDone; ++i) {
    const char ch = data[i];
    // The states where exactly one byte may come.
    static constexpr struct { State at; char want; State next; } kFixed[] = {
        {kDataCr, '\r', kDataLf}, {kDataLf, '\n', kSize}, {kFieldLf, '\n', kFieldStart}, {kLastLf, '\n', kDone}};
    if (auto f = std::find_if(std::begin(kFixed), std::end(kFixed), [&](const auto& x) { return x.at == state_; });
        f != std::end(kFixed)) {
      state_ = ch == f->want ? f->next : kBad;
      continue;
    }
    switch (state_) {
      case kSize:
        if (hex(ch) >= 0 && digits_ < 15) {
          left_ = left_ * 16 + (unsigned)hex(ch);
          ++digits_;
        } else if (digits_ == 0) {
          state_ = kBad;
        } else if (ch == ';') {
          state_ = kExt;
        } else if (ch == ' ' || ch == '\t') {
          state_ = kSizeBlank;
        } else {
          state_ = ch == '\r' ? kSizeLf : kBad;
        }
        break;
      case kSizeBlank:  // BWS is only allowed before an extension's ';'
        if (ch == ';') state_ = kExt;
        else if (ch != ' ' && ch != '\t') state_ = kBad;
        break;
      case kExt:
        if (ch == '\r') state_ = kSizeLf;
        else if (ctl((unsigned char)ch)) state_ = kBad;
        break;
      case kSizeLf:
        state_ = ch != '\n' ? kBad : left_ > 0 ? kData : kFieldStart;
        break;
      case kData: {
        const std::size_t take = (std::size_t)std::min<unsigned long long>(left_, n - i);
        left_ -= take;
        i += take - 1;
        if (left_ == 0) state_ = kDataCr, digits_ = 0;
        break;
      }
      case kFieldStart:
        if (ch == '\r') state_ = kLastLf;
        else state_ = is_tchar((unsigned char)ch) ? kField : kBad;
        break;
      case kField:
        if (++trailer_bytes_ > 8192) state_ = kBad;
        else if (ch == '\r') state_ = kFieldLf;
        else if (ctl((unsigned char)ch)) state_ = kBad;
        break;
      default:
        break;
    }
  }
  return state_ != kBad;
}

bool PeerWatch::gone() {
  if (fd_ < 0) return false;
  short r = poll_one(fd_, POLLRDHUP, 0);
  if (r & (POLLHUP | POLLERR)) return true;  // reset (or both directions shut)
  if (!(r & POLLRDHUP) || probed_) return false;
  if (!http11_) return true;
  probed_ = true;
  static const char probe[] = "HTTP/1.1 100 Continue\r\n\r\n";
  if (::send(fd_, probe, sizeof probe - 1, MSG_NOSIGNAL | MSG_DONTWAIT) < 0 && errno != EAGAIN) return true;
  // A closed socket answers at once (one round trip); a slower reset is seen by a later call.
  return (poll_one(fd_, 0, 100) & (POLLHUP | POLLERR)) != 0;
}

}  // namespace hocurve::server
