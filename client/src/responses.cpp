#include "connection.hpp"

namespace skinspec::client {

std::vector<HttpReply> parse_responses(const std::string& bytes, const std::vector<bool>& heads) {
  std::vector<HttpReply> replies;
  std::size_t offset = 0;
  while (offset < bytes.size()) {
    http::response_parser<http::string_body> parser;
    parser.eager(true);
    parser.skip(replies.size() < heads.size() && heads[replies.size()]);
    beast::error_code ec;
    const std::size_t used = parser.put(asio::buffer(bytes.data() + offset, bytes.size() - offset), ec);
    if (ec || !parser.is_done()) {
      HttpReply broken;
      broken.error =
          "unparsable response at byte " + std::to_string(offset) + (ec ? ": " + ec.message() : ": incomplete");
      replies.push_back(std::move(broken));
      break;
    }
    HttpReply reply;
    copy_head(parser.get(), reply);
    reply.body = parser.get().body();
    replies.push_back(std::move(reply));
    offset += used;
  }
  return replies;
}

}  // namespace skinspec::client
