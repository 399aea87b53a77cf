//! Gateway logic between a PLC (Modbus TCP) and a Hans robot controller.
#![no_std]
