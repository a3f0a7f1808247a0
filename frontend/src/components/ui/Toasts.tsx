import { useEffect } from 'react';
import { useToastStore, type Toast } from '@/stores/toastStore';

const TONE: Record<Toast['tone'], string> = {
  info: 'border-line',
  success: 'border-status-succeeded',
  error: 'border-status-failed',
};

function ToastItem({ toast }: { toast: Toast }) {
  const dismiss = useToastStore((s) => s.dismiss);
  useEffect(() => {
    const timer = setTimeout(() => dismiss(toast.id), 8000);
    return () => clearTimeout(timer);
  }, [toast.id, dismiss]);
  return (
    <li
      className={`flex items-start gap-3 rounded-md border-l-4 bg-raised px-3 py-2 text-sm shadow-lg ${TONE[toast.tone]}`}
    >
      <span className="flex-1">{toast.text}</span>
      <button type="button" aria-label="Dismiss" className="text-muted hover:text-fg" onClick={() => dismiss(toast.id)}>
        ✕
      </button>
    </li>
  );
}

export function Toasts() {
  const toasts = useToastStore((s) => s.toasts);
  return (
    <ol aria-label="Notifications" role="status" className="fixed right-4 bottom-14 z-50 flex w-80 flex-col gap-2">
      {toasts.map((t) => (
        <ToastItem key={t.id} toast={t} />
      ))}
    </ol>
  );
}
