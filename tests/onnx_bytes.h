// Minimal ONNX files written by hand (protobuf wire format), so that tests
// can give the segmenters models of a chosen shape without any tool. Field
// numbers from onnx/onnx.proto (ModelProto, GraphProto, NodeProto,
// TensorProto, ValueInfoProto).
#pragma once

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace dypho {
namespace testing {

inline std::string Varint(uint64_t v) {
  std::string s;
  while (v >= 0x80) {
    s.push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  s.push_back(static_cast<char>(v));
  return s;
}
inline std::string VarintField(int number, uint64_t v) {
  return Varint(static_cast<uint64_t>(number) << 3) + Varint(v);
}
inline std::string BytesField(int number, const std::string& payload) {
  return Varint((static_cast<uint64_t>(number) << 3) | 2) + Varint(payload.size()) + payload;
}

// ValueInfoProto of a float tensor of fixed dims.
inline std::string OnnxValueInfo(const std::string& name, const std::vector<int64_t>& dims) {
  std::string shape;
  for (int64_t d : dims) shape += BytesField(1, VarintField(1, static_cast<uint64_t>(d)));
  const std::string tensor_type = VarintField(1, 1 /* FLOAT */) + BytesField(2, shape);
  return BytesField(1, name) + BytesField(2, BytesField(1, tensor_type));
}

// TensorProto of a 1-D int64 constant (for Reshape shapes, Slice bounds).
inline std::string OnnxInt64Tensor(const std::string& name, const std::vector<int64_t>& values) {
  std::string packed;
  for (int64_t v : values) packed += Varint(static_cast<uint64_t>(v));
  return VarintField(1, values.size()) + VarintField(2, 7 /* INT64 */) + BytesField(7, packed) +
         BytesField(8, name);
}

inline std::string OnnxNode(const std::string& op, const std::vector<std::string>& inputs,
                            const std::vector<std::string>& outputs, const std::string& name) {
  std::string node;
  for (const std::string& i : inputs) node += BytesField(1, i);
  for (const std::string& o : outputs) node += BytesField(2, o);
  return node + BytesField(3, name) + BytesField(4, op);
}

// ModelProto (IR 7, opset 11) of one graph with float input "images" and
// output "output".
inline std::string OnnxModel(const std::vector<std::string>& nodes, const std::vector<std::string>& initializers,
                             const std::vector<int64_t>& input_dims, const std::vector<int64_t>& output_dims) {
  std::string graph;
  for (const std::string& n : nodes) graph += BytesField(1, n);
  graph += BytesField(2, "test_graph");
  for (const std::string& t : initializers) graph += BytesField(5, t);
  graph += BytesField(11, OnnxValueInfo("images", input_dims)) + BytesField(12, OnnxValueInfo("output", output_dims));
  return VarintField(1, 7) + BytesField(8, VarintField(2, 11)) + BytesField(7, graph);
}

inline void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

}  // namespace testing
}  // namespace dypho
