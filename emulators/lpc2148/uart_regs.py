"""The UART's register map, wire constants and records (UM10139, chapters "UART0" and "UART1"),
shared by the model (:mod:`emulators.lpc2148.uart`) and its look-ahead
(:mod:`emulators.lpc2148.uart_horizon`)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, unique
from typing import Final

from emulators.lpc2148.line import FrameFormat

UART0_BASE = 0xE000_C000
UART1_BASE = 0xE001_0000
FIFO_DEPTH = 16
TRIGGER_LEVELS = (1, 4, 8, 14)
#: character times without FIFO activity before the CTI interrupt
CTI_CHARACTERS = 4.0


@unique
class UartReg(IntEnum):
    """Register offsets (UM10139 UART register map tables)."""

    RBR_THR_DLL = 0x00
    IER_DLM = 0x04
    IIR_FCR = 0x08
    LCR = 0x0C
    MCR = 0x10  #: UART1 only
    LSR = 0x14
    MSR = 0x18  #: UART1 only
    SCR = 0x1C
    ACR = 0x20
    FDR = 0x28
    TER = 0x30


@unique
class Iir(IntEnum):
    """IIR values (bits 3:0) by priority."""

    RLS = 0x06
    RDA = 0x04
    CTI = 0x0C
    THRE = 0x02
    NONE = 0x01


class Lsr(IntEnum):
    DR = 0x01
    OE = 0x02
    PE = 0x04
    FE = 0x08
    BI = 0x10
    THRE = 0x20
    TEMT = 0x40
    RXFE = 0x80


_ERRORS = Lsr.OE | Lsr.PE | Lsr.FE | Lsr.BI


@dataclass(frozen=True)
class TxByte:
    """A byte the UART sent: on the line from PCLK tick ``start`` to ``end``."""

    start: float
    end: float
    value: int
    bit_ticks: float
    fmt: FrameFormat


_RBR: Final = int(UartReg.RBR_THR_DLL)
_IER: Final = int(UartReg.IER_DLM)
_IIR: Final = int(UartReg.IIR_FCR)
_LCR: Final = int(UartReg.LCR)
_MCR: Final = int(UartReg.MCR)
_LSR: Final = int(UartReg.LSR)
_MSR: Final = int(UartReg.MSR)
_SCR: Final = int(UartReg.SCR)
_ACR: Final = int(UartReg.ACR)
_FDR: Final = int(UartReg.FDR)
_TER: Final = int(UartReg.TER)
_IIR_RLS: Final = int(Iir.RLS)
_IIR_RDA: Final = int(Iir.RDA)
_IIR_CTI: Final = int(Iir.CTI)
_IIR_THRE: Final = int(Iir.THRE)
_IIR_NONE: Final = int(Iir.NONE)
_DR: Final = int(Lsr.DR)
_OE: Final = int(Lsr.OE)
_PE: Final = int(Lsr.PE)
_FE: Final = int(Lsr.FE)
_BI: Final = int(Lsr.BI)
_THRE: Final = int(Lsr.THRE)
_TEMT: Final = int(Lsr.TEMT)
_RXFE: Final = int(Lsr.RXFE)
_ERROR_BITS: Final = int(_ERRORS)
_INF: Final = float("inf")
