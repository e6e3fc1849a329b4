"""XBee-PRO 802.15.4 pair: API/transparent module emulator and the radio link between them."""

from emulators.xbee.frames import (
    ApiParser,
    AtStatus,
    FrameType,
    ModemStatus,
    TxOption,
    TxStatus,
    at_command,
    at_response,
    checksum,
    encode_frame,
    escape,
    modem_status,
    rx16,
    rx64,
    tx16,
    tx64,
    tx_status,
)
from emulators.xbee.link import RadioLink, RfDelivered, RfFailed
from emulators.xbee.module import XBeeModule
from emulators.xbee.packets import AtCommandHandled, ModeChanged, RfPacket
from emulators.xbee.params import LinkParams, XBeeParams, bd_to_baud

__all__ = [
    "ApiParser", "AtCommandHandled", "AtStatus", "FrameType", "LinkParams", "ModeChanged", "ModemStatus",
    "RadioLink", "RfDelivered", "RfFailed", "RfPacket", "TxOption", "TxStatus", "XBeeModule", "XBeeParams",
    "at_command", "at_response", "bd_to_baud", "checksum", "encode_frame", "escape", "modem_status",
    "rx16", "rx64", "tx16", "tx64", "tx_status",
]
