#include "app/control_protocol.h"

#include <gtest/gtest.h>

#include <string>

namespace mm {
namespace {

using Status = ControlRequestReader::Status;

TEST(ControlRequestReader, CommandSplitAcrossReadsIsOneLine) {
  ControlRequestReader reader;
  EXPECT_EQ(reader.Append("sta"), Status::kNeedMore);
  EXPECT_EQ(reader.Append("tu"), Status::kNeedMore);
  EXPECT_EQ(reader.Append("s\npi"), Status::kComplete);
  EXPECT_EQ(reader.request(), "status");
  EXPECT_EQ(reader.Append("ng\n"), Status::kComplete);  // Kept for Next.
  EXPECT_EQ(reader.request(), "status");
  EXPECT_EQ(reader.Next(), Status::kComplete);
  EXPECT_EQ(reader.request(), "ping");
  EXPECT_EQ(reader.Next(), Status::kNeedMore);
  EXPECT_EQ(reader.buffered(), 0u);
}

TEST(ControlRequestReader, ShutdownEndsTheRequest) {
  ControlRequestReader reader;
  EXPECT_EQ(reader.Append("ping"), Status::kNeedMore);
  EXPECT_EQ(reader.Finish(), Status::kComplete);
  EXPECT_EQ(reader.request(), "ping");
  EXPECT_EQ(reader.Next(), Status::kEmpty);
  ControlRequestReader empty;
  EXPECT_EQ(empty.Finish(), Status::kEmpty);
}

TEST(ControlRequestReader, LongLineIsRefusedWithoutHoldingIt) {
  ControlRequestReader reader(8);
  EXPECT_EQ(reader.Append("12345678"), Status::kNeedMore);
  EXPECT_EQ(reader.Append(std::string(1 << 20, 'x') + "\n"), Status::kTooLong);
  EXPECT_EQ(reader.buffered(), 0u);
  EXPECT_EQ(reader.Append("more"), Status::kTooLong);
  EXPECT_EQ(reader.buffered(), 0u);
  // A line over the limit is refused even when its end of line comes in the same read.
  ControlRequestReader same_read(8);
  EXPECT_EQ(same_read.Append("123456789\n"), Status::kTooLong);
  ControlRequestReader at_limit(8);
  EXPECT_EQ(at_limit.Append("12345678\n"), Status::kComplete);
}

TEST(ParseControlCommand, KnownCommandsAndTelnetLineEnds) {
  EXPECT_EQ(ParseControlCommand("trigger"), ControlCommand::kTrigger);
  EXPECT_EQ(ParseControlCommand("status\r"), ControlCommand::kStatus);
  EXPECT_EQ(ParseControlCommand("ping"), ControlCommand::kPing);
  EXPECT_EQ(ParseControlCommand("watch"), ControlCommand::kWatch);
  EXPECT_EQ(ParseControlCommand("watch\r"), ControlCommand::kWatch);
  EXPECT_EQ(ParseControlCommand("watch all"), ControlCommand::kUnknown);
  EXPECT_EQ(ParseControlCommand("odom 1.5 0 0 0\r"), ControlCommand::kOdom);
  EXPECT_EQ(OdomArguments("odom 1.5 0 0 0\r"), "1.5 0 0 0");
  EXPECT_EQ(ParseControlCommand("odom"), ControlCommand::kUnknown);
  EXPECT_EQ(ParseControlCommand("ping "), ControlCommand::kUnknown);
  EXPECT_EQ(ParseControlCommand(""), ControlCommand::kUnknown);
  EXPECT_EQ(ParseControlCommand(std::string("ping\0", 5)), ControlCommand::kUnknown);
}

}  // namespace
}  // namespace mm
